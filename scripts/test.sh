#!/usr/bin/env bash
# Builds seavio and runs the whole test suite (ctest). Second README command; CI calls it.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
BUILD=${SEAVIO_BUILD_DIR:-build}
# Ninja when installed and the build folder is new (a folder keeps the generator it was made with).
generator=()
[[ ! -f "$BUILD/CMakeCache.txt" ]] && command -v ninja > /dev/null && generator=(-G Ninja)
# Unity build (SEAVIO_UNITY=OFF for one object per .cpp): each target's sources compile in
# batches of 8 per translation unit, so the OpenCV, Eigen, gtest and spdlog headers are parsed
# once per batch; same warnings, all errors (docs/reliability.md, "CI phase times").
# shellcheck disable=SC2086
cmake -S . -B "$BUILD" "${generator[@]}" -DCMAKE_BUILD_TYPE=${SEAVIO_BUILD_TYPE:-Release} \
  -DCMAKE_UNITY_BUILD="${SEAVIO_UNITY:-ON}" ${SEAVIO_CMAKE_ARGS:-}
cmake --build "$BUILD" -j"$(nproc)"
ctest --test-dir "$BUILD" --output-on-failure -j"$(nproc)" --timeout 600
