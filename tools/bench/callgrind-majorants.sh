#!/usr/bin/env bash
# The majorant modes' cost per sample counted by valgrind's callgrind instead of timed: the
# instructions the render tiles execute and callgrind's cycle estimate (instructions + 10 per
# L1 miss + 100 per last-level miss, kcachegrind's "CEst"), per camera sample, for each mode,
# with each mode's ratio to the global bound.
#
# Why: on a shared 2-core machine, timing the same code twice can differ by a third (README,
# "Majorant modes"), so a render-time ratio of 1.15 cannot be told from 1.2, nor a change of
# a few percent in one walk. The instruction counts repeat for the seed: run it twice, get
# the same figures within 0.03 % (the cycle estimate moves by a few percent: the tiles' order follows
# their measured times, and the addresses differ from run to run). Use them to count what a
# change of code adds or removes. They are not time: every instruction counts alike and no
# latency does, so the global bound's long chains of dependent lookups weigh much less here
# than on a real CPU (the dense fog: 1.15x in instructions, 1.38-1.44x timed).
#
# Usage: tools/bench/callgrind-majorants.sh [--spp N] [--estimator E] [scene.gltf ...]
#   (default: 4 spp at 160x120, delta tracking, the fire, the smoke tank, the Cornell smoke)
# Needs valgrind (apt install valgrind) and the release build (cargo build --release), or the
# binary named by BRUME_BIN (to count two builds against each other: copy one aside first).
# One thread; the four modes of a scene run two at a time. Prints a table; asserts nothing.
set -euo pipefail
cd "$(dirname "$0")/../.."

spp=4
estimator=delta
scenes=()
while [ $# -gt 0 ]; do
    case "$1" in
    --spp) spp=$2; shift 2 ;;
    --estimator) estimator=$2; shift 2 ;;
    -h | --help) sed -n '2,21p' "$0"; exit 0 ;;
    *) scenes+=("$1"); shift ;;
    esac
done
[ ${#scenes[@]} -gt 0 ] || scenes=(scenes/fire.gltf scenes/smoke_tank.gltf scenes/cornell_smoke.gltf)

command -v valgrind >/dev/null || { echo "valgrind not found: apt install valgrind" >&2; exit 1; }
bin=${BRUME_BIN:-target/release/brume}
[ -x "$bin" ] || { echo "$bin not found: cargo build --release" >&2; exit 1; }

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

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
    read -r gi gc gn <"$work/$name.global"
    for m in "${modes[@]}"; do
        read -r ir cest n <"$work/$name.$m"
        awk -v s="$name" -v m="$m" -v ir="$ir" -v c="$cest" -v n="$n" -v gi="$gi" -v gc="$gc" -v gn="$gn" \
            'BEGIN { printf "%-22s %-9s %12.0f %12.0f %11.3fx %11.3fx\n", s, m, ir / n, c / n, (gi / gn) / (ir / n), (gc / gn) / (c / n) }'
    done
done
