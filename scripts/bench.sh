#!/usr/bin/env bash
# Builds and runs every Google Benchmark binary (tests/bench/*_bench.cpp) and `seavio bench
# stages`. Results go to stdout and to $OUT (default bench-results/).
#   scripts/bench.sh                 all benchmarks, stage table over 60 frames
#   SEAVIO_BENCH_FILTER=Icp scripts/bench.sh   only benchmarks matching a regex
# Environment: SEAVIO_BUILD_DIR (default build), SEAVIO_JOBS (default 2), OUT,
# SEAVIO_STAGE_FRAMES (default 60). For `seavio bench paper` see docs/benchmarks.md; for
# load-independent instruction counts of the hot paths, scripts/callgrind.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${SEAVIO_BUILD_DIR:-build}
jobs=${SEAVIO_JOBS:-2}
out=${OUT:-bench-results}
filter=${SEAVIO_BENCH_FILTER:-.}
mkdir -p "$out"

cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DSEAVIO_BUILD_BENCHMARKS=ON
benches=()
for src in tests/bench/*_bench.cpp; do benches+=("$(basename "$src" .cpp)"); done
cmake --build "$build" -j"$jobs" --target seavio "${benches[@]}"

for b in "${benches[@]}"; do
  echo "== $b"
  "$build/bench/$b" --benchmark_filter="$filter" --benchmark_repetitions=3 \
    --benchmark_report_aggregates_only=true --benchmark_out="$out/$b.json" --benchmark_out_format=json
done
echo "== seavio bench stages"
"$build/bin/seavio" bench stages --frames "${SEAVIO_STAGE_FRAMES:-60}" --out "$out/stages" --reuse
