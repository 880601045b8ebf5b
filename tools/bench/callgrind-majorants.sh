#!/usr/bin/env bash
# The majorant modes' cost per sample counted by valgrind's callgrind instead of timed: the
# instructions the render tiles execute and callgrind's cycle estimate (instructions + 10 per
# L1 miss + 100 per last-level miss, kcachegrind's "CEst"), per camera sample, for each mode,
# with each mode's ratio to the global bound.
#
# Why: on a busy machine, timing the same code twice can differ by a third, so a render-time
# ratio of 1.15 cannot be told from 1.2, nor a change of
# a few percent in one walk. The instruction counts repeat for the seed: run it twice, get
# the same figures within 0.03 % (the cycle estimate moves by a few percent: the tiles' order follows
# their measured times, and the addresses differ from run to run). Use them to count what a
# change of code adds or removes. They are not time: every instruction counts alike and no
# latency does, so the global bound's long chains of dependent lookups weigh much less here
# than on a real CPU (the dense fog: 1.15x in instructions, 1.38-1.44x timed).
#
# With --floor, each scene is also counted with its media made transparent (every
# BRUME_medium_vdb's densityScale times 1e-6, in a copy of the scene written beside it and
# removed after) under the global walk: the same rays, span searches, views and walk entries,
# and almost no tentative collision. No walk can make fewer collisions than none, so the
# global bound's count over this floor is the most any majorant structure could gain on the
# scene (`floor` row, `instr gl/x`). The floor is generous: the transparent medium scatters
# nowhere, so its paths spawn none of the rays that real collisions do. Scenes whose media
# emit get no floor row: their walks must still sample the emission.
#
# Usage: tools/bench/callgrind-majorants.sh [--spp N] [--estimator E] [--floor] [scene.gltf ...]
#   (default: 4 spp at 160x120, delta tracking, the fire, the smoke tank, the Cornell smoke)
# Needs valgrind (apt install valgrind) and the release build (cargo build --release), or the
# binary named by BRUME_BIN (to count two builds against each other: copy one aside first).
# One thread; the four modes of a scene run two at a time. Prints a table; asserts nothing.
set -euo pipefail
cd "$(dirname "$0")/../.."

spp=4
estimator=delta
floor=0
scenes=()
while [ $# -gt 0 ]; do
    case "$1" in
    --spp) spp=$2; shift 2 ;;
    --estimator) estimator=$2; shift 2 ;;
    --floor) floor=1; shift ;;
    -h | --help) sed -n '2,30p' "$0"; exit 0 ;;
    *) scenes+=("$1"); shift ;;
    esac
done
[ ${#scenes[@]} -gt 0 ] || scenes=(scenes/fire.gltf scenes/smoke_tank.gltf scenes/cornell_smoke.gltf)

command -v valgrind >/dev/null || { echo "valgrind not found: apt install valgrind" >&2; exit 1; }
bin=${BRUME_BIN:-target/release/brume}
[ -x "$bin" ] || { echo "$bin not found: cargo build --release" >&2; exit 1; }

work=$(mktemp -d)
floor_scenes=()
trap 'rm -rf "$work" "${floor_scenes[@]}"' EXIT

# Writes the transparent copy of scene $1 beside it (so its relative URIs resolve) and prints
# its path; prints nothing when a medium emits or none is a VDB medium.
transparent_copy() {
    python3 - "$1" <<'PY'
import json, os, sys
src = sys.argv[1]
scene = json.load(open(src))
media = [n["extensions"]["BRUME_medium_vdb"] for n in scene.get("nodes", [])
         if "BRUME_medium_vdb" in n.get("extensions", {})]
if not media or any("emissionGrid" in m or "temperatureGrid" in m for m in media):
    sys.exit(0)
for m in media:
    m["densityScale"] = m.get("densityScale", 1.0) * 1e-6
out = os.path.join(os.path.dirname(src) or ".", ".floor-" + os.path.basename(src))
json.dump(scene, open(out, "w"))
print(out)
PY
}

# One render under callgrind, counting only inside the tiles (scene loading and the
# structures' builds are left out); writes "<Ir> <CEst> <samples>" to $work/<key>.
count() {
    local scene=$1 mode=$2 key=$3
    # The VDB files are read in the watched process: callgrind cannot follow the re-executed
    # reader (`brume_ffi::IN_PROCESS_ENV`).
    BRUME_VDB_IN_PROCESS=1 RAYON_NUM_THREADS=1 valgrind --tool=callgrind --cache-sim=yes \
        --callgrind-out-file="$work/$key.out" '--toggle-collect=*render_tile*' \
        "$bin" render "$scene" -o "$work/$key.exr" --width 160 --height 120 --spp "$spp" \
        --majorant "$mode" --estimator "$estimator" --backend cpu >"$work/$key.log" 2>&1 || {
        echo "render failed: $scene --majorant $mode (log below)" >&2
        cat "$work/$key.log" >&2
        return 1
    }
    local events
    events=$(grep -E '^(summary|totals):' "$work/$key.out" | head -1 | cut -d' ' -f2-)
    # Events: Ir Dr Dw I1mr D1mr D1mw ILmr DLmr DLmw
    read -r ir _ _ i1 d1r d1w il dlr dlw <<<"$events"
    local samples
    samples=$(grep -oE 'totals: samples [0-9]+' "$work/$key.log" | grep -oE '[0-9]+$')
    echo "$ir $((ir + 10 * (i1 + d1r + d1w) + 100 * (il + dlr + dlw))) $samples" >"$work/$key"
}

modes=(global leaf culled adaptive)
printf '%s\n' "majorant modes counted by callgrind (160x120, $spp spp, 1 thread, $estimator; per camera sample)"
printf '%-22s %-9s %12s %12s %12s %12s\n' scene bounds "instr" "CEst" "instr gl/x" "CEst gl/x"
for scene in "${scenes[@]}"; do
    name=$(basename "$scene" .gltf)
    pids=()
    for i in "${!modes[@]}"; do
        count "$scene" "${modes[$i]}" "$name.${modes[$i]}" &
        pids+=($!)
        # Two at a time: the counts do not depend on the load.
        if [ $((i % 2)) -eq 1 ]; then
            for p in "${pids[@]}"; do wait "$p"; done
            pids=()
        fi
    done
    for p in "${pids[@]}"; do wait "$p"; done
    rows=("${modes[@]}")
    if [ "$floor" = 1 ]; then
        copy=$(transparent_copy "$scene")
        if [ -n "$copy" ]; then
            floor_scenes+=("$copy")
            count "$copy" global "$name.floor"
            rows+=(floor)
        fi
    fi
    read -r gi gc gn <"$work/$name.global"
    for m in "${rows[@]}"; do
        read -r ir cest n <"$work/$name.$m"
        awk -v s="$name" -v m="$m" -v ir="$ir" -v c="$cest" -v n="$n" -v gi="$gi" -v gc="$gc" -v gn="$gn" \
            'BEGIN { printf "%-22s %-9s %12.0f %12.0f %11.3fx %11.3fx\n", s, m, ir / n, c / n, (gi / gn) / (ir / n), (gc / gn) / (c / n) }'
    done
done
