#!/usr/bin/env bash
# One-command libFuzzer runs.
#   scripts/fuzz.sh smoke [SECONDS]   build the fuzz targets (clang, build-fuzz) and run each for
#                                     SECONDS (default 20) over its committed seed corpus, SEAVIO_JOBS
#                                     targets side by side: the CI job
#   scripts/fuzz.sh long SECONDS      longer runs, one target at a time; new inputs accumulate in
#                                     build-fuzz/corpus_long/<target> between runs
#   scripts/fuzz.sh list              the target names
# Environment: SEAVIO_FUZZ_TARGETS (space-separated names, default all), SEAVIO_JOBS (build jobs and
#   smoke targets at once, default 2).
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
# One target: prints its table row (and, on failure, the first report line and the crash
# inputs) and returns non-zero if the target failed.
run_one() {
  local t=$1 bin="$build/fuzz/fuzz_$1" seeds="fuzz/corpus/$1" work log status execs rate last crashes result
  [[ -x "$bin" && -d "$seeds" ]] || { echo "$t: no binary $bin or no corpus $seeds" >&2; return 1; }
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
  local common=(-max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len=65536
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
  fi
  printf '%-20s %8s %12s %8s %8s  %s\n' "$t" "$seconds" "${execs:-?}" "${rate:-?}" "$crashes" "$result"
  if [[ $status -ne 0 ]]; then
    grep -m 1 -E "ERROR: |runtime error|SUMMARY" "$log" >&2 || true
    find "$build/artifacts" -maxdepth 1 -name "$t-*" >&2
  fi
  [[ "$result" == ok ]]
}

# Smoke runs go $jobs at a time: each target is one single-threaded process with its own
# corpus, log and artifact prefix, so running them side by side changes nothing but the wall
# time (CI: 10 targets x 10 s, 100 s one at a time, 50 s two at a time). Long runs stay one at
# a time, so each gets a whole core for its SECONDS. Rows print in target order either way.
parallel=1
[[ "$mode" == smoke ]] && parallel=$jobs
failed=0
running=0
for t in "${targets[@]}"; do
  if (( running >= parallel )); then
    wait -n || true
    running=$((running - 1))
  fi
  ( run_one "$t" > "$build/logs/$t.$mode.row" 2>&1; echo $? > "$build/logs/$t.$mode.rc" ) &
  running=$((running + 1))
done
wait
printf '%-20s %8s %12s %8s %8s  %s\n' target seconds executions exec/s crashes result
for t in "${targets[@]}"; do
  cat "$build/logs/$t.$mode.row"
  [[ "$(cat "$build/logs/$t.$mode.rc" 2>/dev/null)" == 0 ]] || failed=1
done
exit $failed
