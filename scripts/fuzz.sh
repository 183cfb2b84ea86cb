#!/usr/bin/env bash
# One-command libFuzzer runs (issue 9, "Bad input tried").
#   scripts/fuzz.sh smoke [SECONDS]   build the fuzz targets (clang, build-fuzz) and run each for
#                                     SECONDS (default 20) over its committed seed corpus: the CI job
#   scripts/fuzz.sh long SECONDS      longer runs, one target at a time; new inputs accumulate in
#                                     build-fuzz/corpus_long/<target> between runs
#   scripts/fuzz.sh list              the target names
# Environment: SEAVIO_FUZZ_TARGETS (space-separated names, default all), SEAVIO_JOBS (build, default 2).
# The committed corpora in fuzz/corpus/ are only read; new inputs go to the build tree and crash
# inputs to build-fuzz/artifacts/<target>-crash-*. Prints executions and crashes per target.
# Exit status: 0 if no target crashed, 1 otherwise, 2 on bad usage.
set -euo pipefail
cd "$(dirname "$0")/.."

mode=${1:-}
case "$mode" in
  smoke) seconds=${2:-20} ;;
  long) seconds=${2:-} ;;
  list) seconds=0 ;;
  *)
    echo "usage: $0 smoke [SECONDS] | long SECONDS | list" >&2
    exit 2
    ;;
esac
[[ "$seconds" =~ ^[1-9][0-9]*$ || "$mode" == list ]] || { echo "$0: SECONDS must be a positive whole number" >&2; exit 2; }

all_targets=()
for d in fuzz/corpus/*/; do all_targets+=("$(basename "$d")"); done
if [[ "$mode" == list ]]; then
  printf '%s\n' "${all_targets[@]}"
  exit 0
fi
read -r -a targets <<< "${SEAVIO_FUZZ_TARGETS:-${all_targets[*]}}"

build=build-fuzz
jobs=${SEAVIO_JOBS:-2}
mkdir -p "$build"
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_C_COMPILER=clang \
  -DSEAVIO_FUZZ=ON -DSEAVIO_BUILD_TESTS=OFF -DSEAVIO_BUILD_BENCHMARKS=OFF > "$build/configure.log" 2>&1 ||
  { cat "$build/configure.log" >&2; exit 1; }
cmake --build "$build" -j"$jobs" --target "${targets[@]/#/fuzz_}" > "$build/build.log" 2>&1 ||
  { tail -n 50 "$build/build.log" >&2; exit 1; }

mkdir -p "$build/artifacts" "$build/logs"
failed=0
printf '%-20s %8s %12s %8s %8s  %s\n' target seconds executions exec/s crashes result
for t in "${targets[@]}"; do
  bin="$build/fuzz/fuzz_$t"
  seeds="fuzz/corpus/$t"
  [[ -x "$bin" && -d "$seeds" ]] || { echo "$t: no binary $bin or no corpus $seeds" >&2; failed=1; continue; }
  if [[ "$mode" == smoke ]]; then
    work="$build/corpus_smoke/$t"
    rm -rf "$work"
  else
    work="$build/corpus_long/$t"
  fi
  mkdir -p "$work"
  log="$build/logs/$t.$mode.log"
  rm -f "$build/artifacts/$t"-*
  status=0
  # -rss_limit_mb: a reader must never need gigabytes for a few kilobytes of input.
  common=(-max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len=65536
          -artifact_prefix="$build/artifacts/$t-")
  if [[ "$mode" == smoke ]]; then
    "$bin" "$work" "$seeds" "${common[@]}" -print_final_stats=1 > "$log" 2>&1 || status=$?
    execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
    rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -n 1)
  else
    # Fork mode keeps going after a crash, so one known bug does not hide the next one.
    "$bin" "$work" "$seeds" "${common[@]}" -fork=1 -ignore_crashes=1 -ignore_ooms=1 -ignore_timeouts=1 \
      > "$log" 2>&1 || status=$?
    last=$(grep -E '^#[0-9]+: cov:' "$log" | tail -n 1)
    execs=$(sed -E 's/^#([0-9]+):.*/\1/' <<< "$last")
    rate=$(sed -nE 's/.*exec\/s:? ([0-9]+).*/\1/p' <<< "$last")
  fi
  crashes=$(find "$build/artifacts" -maxdepth 1 -name "$t-*" | wc -l)
  result=ok
  if [[ $status -ne 0 || $crashes -ne 0 ]]; then
    result="FAILED (exit $status, log $log)"
    failed=1
  fi
  printf '%-20s %8s %12s %8s %8s  %s\n' "$t" "$seconds" "${execs:-?}" "${rate:-?}" "$crashes" "$result"
  if [[ $status -ne 0 ]]; then
    grep -m 1 -E "ERROR: |runtime error|SUMMARY" "$log" >&2 || true
    find "$build/artifacts" -maxdepth 1 -name "$t-*" >&2
  fi
done
exit $failed
