#!/usr/bin/env bash
# One-command sanitizer run; .ci/run calls both modes.
#   scripts/sanitize.sh address   ASan+UBSan build in build-asan, whole ctest suite
#   scripts/sanitize.sh thread    TSan build in build-tsan of the daemon and LCM test executables
#                                 (and the seaviod they run), every test in them but two (below)
# Environment: SEAVIO_JOBS (default 2: the machine is shared), SEAVIO_CTEST_ARGS (extra ctest args),
#   SEAVIO_UNITY (default ON: unity build, see below),
#   SEAVIO_SAN_FLAGS (optimisation and debug flags, default "-O1 -g1 -DNDEBUG -Wno-stringop-overflow
#   -Wno-array-bounds -Wno-maybe-uninitialized":
#   -O1 is what the sanitizers recommend, cheaper to compile than -O2 -g, file:line still in
#   reports; GCC 12 reports impossible memset bounds (stringop-overflow, array-bounds) once TSan's
#   instrumentation changes its inlining, e.g. in tests/drivers/lcm/lcm_log_replay_test.cpp, and
#   at -O1 with ASan a "maybe uninitialized" variable that every path using it has set (the
#   albedo in tools/simulate/seafloor_renderer.cpp, before that file was built uninstrumented:
#   set in both branches that make l > 0). The Release build of the test phase keeps all three
#   warnings as errors. The simulator's pixel-making files build without instrumentation at
#   -O2: tools/simulate/CMakeLists.txt.)
# The end-to-end daemon tests detect the sanitizer at compile time and stretch their waits
# (tests/daemon/seaviod_e2e_test.cpp), so they run here rather than being skipped.
# Prints the build and test times. Exit status: non-zero if the build, any test or any sanitizer
# report failed, 2 on bad usage.
set -euo pipefail
cd "$(dirname "$0")/.."

mode=${1:-address}
jobs=${SEAVIO_JOBS:-2}
flags=${SEAVIO_SAN_FLAGS:--O1 -g1 -DNDEBUG -Wno-stringop-overflow -Wno-array-bounds -Wno-maybe-uninitialized}
case "$mode" in
  address)
    build=build-asan
    targets=(--target all)  # every test binary and the seavio/seaviod executables they run
    filter=()
    # Fail on the first report; leaks count as failures (LeakSanitizer is on by default with ASan).
    export ASAN_OPTIONS=${ASAN_OPTIONS:-abort_on_error=1:detect_leaks=1:strict_string_checks=1}
    export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
    ;;
  thread)
    build=build-tsan
    # Only what the threaded tests need, so the TSan build stays small: test_daemon (and the
    # seaviod/seavio it runs) and the LCM driver tests. All their tests run (rings, workers,
    # scheduling, global thread, faults, end to end); the executables not built here leave a
    # placeholder test <name>_NOT_BUILT in ctest, which is what -E leaves out.
    # (The seavio CLI is built for that one left-out test only, so not here: tests/daemon/CMakeLists.txt.)
    targets=(--target test_daemon test_drivers_lcm seaviod)
    # SeaviodE2E.AravisStereoAndSerialImuGivePosesAsAccurateAsSeavioRun is left out here and
    # only here (it runs in the Release and ASan phases): it is an accuracy test that needs the
    # daemon to keep up with 5 fps stereo, and under TSan seaviod processes ~10 of ~100 frames
    # on a 2-core machine. Its threads (Aravis cameras, serial IMU, rings, workers, LCM) are the
    # same ones SeaviodE2E.SurvivesCameraRestartImuSilenceAndSerialGarbageCountingEach drives
    # under TSan, with faults on top.
    # SeaviodE2E.RecordedLiveRunReplaysToThePosesItPublished is left out for the same reason
    # as the CLI: its second half runs `seavio replay`. The replay's daemon threads (blocking
    # pushes from a log) run under TSan in GlobalThread.ReplayPublishesLocalAndRefinedPoses...
    # and DaemonInputs.FarFutureStampInAReplayedLogDoesNotStallTheReplay, the recorder's in
    # Recorder.*.
    filter=(-E "_NOT_BUILT$|SeaviodE2E.AravisStereoAndSerialImuGivePosesAsAccurateAsSeavioRun|SeaviodE2E.RecordedLiveRunReplaysToThePosesItPublished")
    # ignore_noninstrumented_modules: memcpy/memset/recv that uninstrumented libraries
    # (Aravis' GVSP stream and fake-camera threads, GLib) call through TSan's interceptors no
    # longer write shadow memory. Every GVSP packet Aravis copied into a frame buffer was
    # otherwise checked against our instrumented reads of that buffer and reported (then
    # suppressed) as a race, hundreds of times a second: the end-to-end daemon tests ran at a
    # fraction of real time, lost frames and never paired a stereo frame. Our own
    # code's accesses and every pthread lock and atomic are still tracked.
    export TSAN_OPTIONS=${TSAN_OPTIONS:-halt_on_error=1:second_deadlock_stack=1:ignore_noninstrumented_modules=1:suppressions=$PWD/scripts/tsan.supp}
    ;;
  *)
    echo "usage: $0 [address|thread]" >&2
    exit 2
    ;;
esac

t0=$(date +%s)
mkdir -p "$build"
# Unity build (SEAVIO_UNITY=OFF for one object per .cpp, e.g. to find which file a report
# names by object): each target's sources compile as batches of 8 in one translation unit,
# so OpenCV, Eigen, gtest and spdlog headers are parsed, and their templates instantiated
# and instrumented, once per batch instead of once per file: docs/reliability.md,
# "CI phase times". Ninja when installed and the build folder is new (a folder keeps its
# generator).
unity=${SEAVIO_UNITY:-ON}
generator=()
[[ ! -f "$build/CMakeCache.txt" ]] && command -v ninja > /dev/null && generator=(-G Ninja)
cmake -S . -B "$build" "${generator[@]}" -DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=$flags" \
  -DCMAKE_UNITY_BUILD="$unity" -DSEAVIO_SANITIZE="$mode" -DSEAVIO_BUILD_BENCHMARKS=OFF > "$build/configure.log" 2>&1 ||
  { cat "$build/configure.log" >&2; exit 1; }
cmake --build "$build" -j"$jobs" "${targets[@]}" 2>&1 | tail -n 80
t1=$(date +%s)
status=0
# shellcheck disable=SC2086
ctest --test-dir "$build" --output-on-failure -j"$jobs" --timeout 900 "${filter[@]}" ${SEAVIO_CTEST_ARGS:-} || status=$?
t2=$(date +%s)
echo "sanitize.sh $mode: build $((t1 - t0)) s, tests $((t2 - t1)) s, exit $status"
exit $status
