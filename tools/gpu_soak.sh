#!/usr/bin/env bash
# Runs the GPU test binary (tests/gpu/) N times in a row and prints, per binary, how
# many runs passed, failed or crashed (killed by a signal: SIGSEGV, SIGABRT from glibc's heap
# checks). A crash is what a heap corruption looks like on lavapipe, where storage buffers
# live in the process heap; a failure is a test's own assertion.
#
#   tools/gpu_soak.sh [N] [BINARY_FILTER] [-- TEST_FILTER...]
#
# N defaults to 50. BINARY_FILTER (an extended grep pattern, default "gpu") picks the binaries;
# arguments after `--` go to each binary (e.g. `render::` for one module, or a test name and
# --exact). With
# MESA_SHADER_CACHE_DISABLE=true every run compiles its kernels afresh, which is where driver
# compiler bugs show. Logs of crashed or failed runs are kept under $SOAK_LOGS (default a
# temporary folder), named binary-run.log. Exit status 1 if any run crashed or failed.
set -uo pipefail
cd "$(dirname "$0")/.."
n=${1:-50}
filter=${2:-gpu}
shift $(( $# >= 2 ? 2 : $# ))
[ "${1:-}" = "--" ] && shift
logs=${SOAK_LOGS:-$(mktemp -d)}
mkdir -p "$logs"
cargo test --release --no-run --message-format=json 2>/dev/null \
    | grep -o '"executable":"[^"]*"' | cut -d'"' -f4 | grep -E "/($filter)-[0-9a-f]+$" \
    | grep -v '\.d$' | sort -u > "$logs/binaries"
[ -s "$logs/binaries" ] || { echo "no test binary matches $filter"; exit 2; }
bad=0
printf '%-22s %5s %6s %6s %7s %9s\n' binary runs passed failed crashed "s/run"
while read -r bin; do
    name=$(basename "$bin" | sed 's/-[0-9a-f]*$//')
    passed=0 failed=0 crashed=0
    start=$(date +%s.%N)
    for ((i = 1; i <= n; i++)); do
        "$bin" "$@" > "$logs/$name-$i.log" 2>&1
        rc=$?
        if [ $rc -eq 0 ]; then
            passed=$((passed + 1))
            rm -f "$logs/$name-$i.log"
        elif [ $rc -gt 128 ]; then
            crashed=$((crashed + 1))
            echo "  $name run $i: killed by signal $((rc - 128)), log $logs/$name-$i.log"
        else
            failed=$((failed + 1))
            echo "  $name run $i: failed (exit $rc), log $logs/$name-$i.log"
        fi
    done
    secs=$(echo "$(date +%s.%N) - $start" | bc -l)
    printf '%-22s %5d %6d %6d %7d %9.1f\n' "$name" "$n" "$passed" "$failed" "$crashed" \
        "$(echo "$secs / $n" | bc -l)"
    [ $((failed + crashed)) -gt 0 ] && bad=1
done < "$logs/binaries"
exit $bad
