#!/usr/bin/env bash
# One-command sanitizer run (issue 9).
#   scripts/sanitize.sh address   ASan+UBSan build in build-asan, whole ctest suite
#   scripts/sanitize.sh thread    TSan build in build-tsan, threaded daemon/ring/worker/LCM tests only
# Environment: SEAVIO_JOBS (default 2: the machine is shared), SEAVIO_CTEST_ARGS (extra ctest args).
# Exit status: ctest's (non-zero if any test or sanitizer report failed), 2 on bad usage.
set -euo pipefail
cd "$(dirname "$0")/.."

mode=${1:-address}
jobs=${SEAVIO_JOBS:-2}
case "$mode" in
  address)
    build=build-asan
    targets=()            # everything
    filter=()
    # Fail on the first report; leaks count as failures (LeakSanitizer is on by default with ASan).
    export ASAN_OPTIONS=${ASAN_OPTIONS:-abort_on_error=1:detect_leaks=1:strict_string_checks=1}
    export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
    ;;
  thread)
    build=build-tsan
    # Only what the threaded tests need, so the TSan build stays small.
    targets=(--target test_daemon test_drivers_lcm seaviod)
    filter=(-R "Daemon|Ring|Worker|Seaviod|Lcm")
    export TSAN_OPTIONS=${TSAN_OPTIONS:-halt_on_error=1:second_deadlock_stack=1:suppressions=$PWD/scripts/tsan.supp}
    ;;
  *)
    echo "usage: $0 [address|thread]" >&2
    exit 2
    ;;
esac

# RelWithDebInfo: optimised enough to finish, with line numbers in the reports.
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSEAVIO_SANITIZE="$mode" -DSEAVIO_BUILD_BENCHMARKS=OFF
cmake --build "$build" -j"$jobs" "${targets[@]}"
# shellcheck disable=SC2086
ctest --test-dir "$build" --output-on-failure -j"$jobs" --timeout 900 "${filter[@]}" ${SEAVIO_CTEST_ARGS:-}
