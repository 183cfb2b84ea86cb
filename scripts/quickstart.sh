#!/usr/bin/env bash
# The main job on an embedded default: build, simulate a short seafloor survey (unless a
# dataset folder is given), run the odometry, print accuracy and per-stage timing, plot.
#   bash scripts/quickstart.sh [DATASET_DIR] [local|global]
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
BUILD=${SEAVIO_BUILD_DIR:-build}
cmake -S . -B "$BUILD" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$BUILD" -j"$(nproc)" --target seavio
SEAVIO="$BUILD/bin/seavio"
OUT=out/quickstart
mkdir -p "$OUT"
DATASET=${1:-}
MODE=${2:-local}
if [[ -z "$DATASET" ]]; then
  DATASET="$OUT/short-plain"
  if [[ ! -f "$DATASET/mav0/cam0/data.csv" ]]; then
    "$SEAVIO" simulate short-plain --seed 11 --out "$DATASET" --force
  fi
fi
"$SEAVIO" run --dataset "$DATASET" --mode "$MODE" --out "$OUT/trajectory.txt" --stats "$OUT/stats.json" --quiet
"$SEAVIO" eval --gt "$DATASET" --est "$OUT/trajectory.txt" --plot "$OUT/trajectory.png" --json "$OUT/accuracy.json"
echo "quickstart: trajectory $OUT/trajectory.txt, plot $OUT/trajectory.png, stats $OUT/stats.json"
