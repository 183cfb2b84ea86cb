#!/usr/bin/env bash
# Daemon latency under real-time replay: seaviod replays a recorded 640 x 480,
# 15 fps stereo + IMU log itself (`daemon.lcm.input_url: file://LOG?speed=1`, the camera and
# IMU drivers `lcm`, live settings: drain_to_newest true, backpressure false), publishes its
# poses and status over UDP multicast inside a private network namespace, lcm-logger
# records them, and `seavio profile` measures each run. Dropped = the daemon's own counters at
# exit (dropped in the camera ring, at shutdown, missing upstream) plus pose sequence gaps. RUNS runs per mode, then one line
# per run and the medians, with a pass/fail line against the goal (p99 <= 33 ms, 0 dropped).
#
# Latency basis: the replayed stamps are on the dataset's clock, not the daemon's, so
# `seavio profile` reports receipt to publish per frame (end_to_end) and, for a real-time
# replay, capture to publish with the stamp moved onto the daemon clock by the replay's
# offset (capture_to_publish_replay: the camera thread's decode counted too). The verdict
# uses the latter, the larger of the two. Each run also reports the CPU time that other
# processes' real-time threads able to preempt the daemon used meanwhile (a shared machine's
# `chrt -f 50` benchmark): a run with rival CPU measured the machine, not the daemon.
#
# usage: scripts/latency.sh [--rt | --no-rt] [--runs N] [--modes "local global"]
#                           [--frames N] [--seed S] [--imu-hold-ms MS] [--build DIR]
#                           [--work DIR] [--keep]
#   --rt        (default) the daemon at SCHED_FIFO 20, as systemd/seaviod.service starts it
#               (chrt -f 20; its map ICP and status threads demote themselves to SCHED_BATCH);
#               lcm-logger at SCHED_FIFO 19 so the recording never lags. Needs root.
#   --no-rt     normal scheduling (on a shared machine this measures the other load)
#   --runs      runs per mode (default 3)
#   --modes     odometry modes (default "local global")
#   --frames    length of the simulated survey (default 300 = 20 s at 15 fps)
#   --seed      simulator seed (default 11, a tuning seed)
#   --imu-hold-ms  daemon.imu_hold_ms (default 0, the shipped config/seavio.yaml value)
#   --build     build folder holding bin/seavio and bin/seaviod (default: build)
#   --work      scratch folder (default: a new /tmp/seavio_latency.XXXXXX); the simulated
#               survey and its log are reused if already there
#   --keep      keep the scratch folder
# Exit status: 0 every run met the goal, 1 a run missed it, 2 usage or set-up error.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
# shellcheck source-path=SCRIPTDIR source=lib/daemon_run.sh
source "$here/scripts/lib/daemon_run.sh"
rt=1
runs=3
modes="local global"
frames=300
seed=11
imu_hold_ms=0
build="$here/build"
work=""
keep=0
goal_p99_ms=33
while [[ $# -gt 0 ]]; do
  case "$1" in
    --rt) rt=1 ;;
    --no-rt) rt=0 ;;
    --runs) runs="$2"; shift ;;
    --modes) modes="$2"; shift ;;
    --frames) frames="$2"; shift ;;
    --seed) seed="$2"; shift ;;
    --imu-hold-ms) imu_hold_ms="$2"; shift ;;
    --build) build="$(cd "$2" && pwd)"; shift ;;
    --work) work="$2"; shift ;;
    --keep) keep=1 ;;
    -h|--help) sed -n '2,34p' "$0"; exit 0 ;;
    *) echo "latency.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
  shift
done
[[ "$runs" =~ ^[1-9][0-9]*$ ]] || { echo "latency.sh: --runs must be a positive integer" >&2; exit 2; }
seavio="$build/bin/seavio"
seaviod="$build/bin/seaviod"
seavio_need_bins latency.sh "$build"
seavio_need_tools latency.sh lcm-logger unshare ip chrt
if [[ $rt == 1 && $EUID -ne 0 ]]; then
  echo "latency.sh: --rt needs root (SCHED_FIFO and a network namespace without a user namespace)" >&2
  exit 2
fi

if [[ -z "$work" ]]; then
  work="$(mktemp -d /tmp/seavio_latency.XXXXXX)"
  [[ $keep == 1 ]] || trap 'rm -rf "$work"' EXIT
fi
mkdir -p "$work"
work="$(cd "$work" && pwd)"
seavio_survey_log "$seavio" "$work" "$frames" "$seed"

url="$SEAVIO_LCM_URL"
# A user namespace (unshare -r) would take away the right to SCHED_FIFO: as root, a
# network namespace alone.
# rival_prio: other processes' real-time threads from this priority up preempt the daemon
# (seavio_rival_cpu, scripts/lib/daemon_run.sh); their CPU time during a run is reported beside its figures.
if [[ $rt == 1 ]]; then ns="unshare -n"; daemon_prio="chrt -f 20"; logger_prio="chrt -f 19"; rival_prio=20
else ns="unshare -rn"; daemon_prio=""; logger_prio=""; rival_prio=1; fi

summary="$work/summary.csv"
echo "mode,run,p50_ms,p99_ms,max_ms,receipt_p50_ms,receipt_p99_ms,frames,dropped,seq_gaps,processed,frames_in,rival_rt_cpu_s" > "$summary"
echo "latency: $runs run(s) per mode ($modes), $( [[ $rt == 1 ]] && echo "daemon SCHED_FIFO 20" || echo "normal scheduling"), imu_hold_ms $imu_hold_ms, load average $(cut -d' ' -f1-3 /proc/loadavg)"
for mode in $modes; do
  for run in $(seq 1 "$runs"); do
    d="$work/$mode-$run"
    mkdir -p "$d"
    cat > "$d/daemon.yaml" <<EOF
daemon:
  processor: odometry
  calibration_dataset: "$work/seq"
  camera: {driver: lcm}
  imu: {driver: lcm}
  drain_to_newest: true
  backpressure: false
  imu_hold_ms: $imu_hold_ms
  status_period_ms: 1000
  lcm: {url: "$url", input_url: "file://$work/survey.lcmlog?speed=1"}
odometry:
  mode: $mode
EOF
    export LAT_DIR="$d" LAT_URL="$url" LAT_SEAVIOD="$seaviod" LAT_DAEMON_PRIO="$daemon_prio" LAT_LOGGER_PRIO="$logger_prio"
    export LAT_RIVAL_PRIO="$rival_prio"
    $ns bash -c '
set -euo pipefail
source "$SEAVIO_DAEMON_RUN_LIB"
seavio_ns_multicast
$LAT_LOGGER_PRIO lcm-logger --lcm-url="$LAT_URL" -c "SEAVIO_POSE|SEAVIO_STATUS" --force "$LAT_DIR/out.lcmlog" > "$LAT_DIR/logger.log" 2>&1 &
logger=$!
sleep 0.5
$LAT_DAEMON_PRIO "$LAT_SEAVIOD" --config "$LAT_DIR/daemon.yaml" > "$LAT_DIR/seaviod.log" 2>&1 &
daemon=$!
# Every second: CPU [s] of other processes real-time threads able to preempt the daemon.
rm -f "$LAT_DIR/rival.state" "$LAT_DIR/rival.txt"
while kill -0 $daemon 2>/dev/null; do
  seavio_rival_cpu "$LAT_DIR/rival.state" "$LAT_RIVAL_PRIO" "$$ $daemon $logger" >> "$LAT_DIR/rival.txt"
  sleep 1
done
rc=0
wait $daemon || rc=$?
sleep 0.5
kill -INT $logger
wait $logger || true
exit $rc
' || { echo "latency: seaviod failed in $d (exit $?):"; tail -n 20 "$d/seaviod.log"; exit 2; }
    "$seavio" profile "$d/out.lcmlog" --json "$d/profile.json" > "$d/profile.txt"
    # The daemon's own counters at exit (its summary) are the authority on drops: frames
    # that never reached a pose leave no trace in the recorded log's sequence numbers when
    # they are the last ones.
    grep -qE '^ +frames in [0-9]+, processed' "$d/seaviod.log" || { echo "latency: no frame counters in $d/seaviod.log"; exit 2; }
    frames_in=$(seavio_exit_counter "$d/seaviod.log" "frames in")
    processed=$(seavio_exit_counter "$d/seaviod.log" "processed")
    dropped=$(( $(seavio_exit_counter "$d/seaviod.log" "dropped in ring") + $(seavio_exit_counter "$d/seaviod.log" "dropped at shutdown") + $(seavio_exit_counter "$d/seaviod.log" "missing upstream \(seq gaps\)") ))
    jstat() { seavio_jstat "$d/profile.json" "$1" "$2"; }  # jstat NAME FIELD of this run
    echo "$mode,$run,$(jstat capture_to_publish_replay p50_ms),$(jstat capture_to_publish_replay p99_ms),$(jstat capture_to_publish_replay max_ms),$(jstat end_to_end p50_ms),$(jstat end_to_end p99_ms),$(grep -m1 -o '"frames": [0-9]*' "$d/profile.json" | grep -o '[0-9]*$'),$dropped,$(grep -m1 -o '"seq_gaps": [0-9]*' "$d/profile.json" | grep -o '[0-9]*$'),$processed,$frames_in,$(awk '{ c += $1 } END { printf "%.1f", c }' "$d/rival.txt")" >> "$summary"
    tail -n 1 "$summary" | awk -F, '{ printf "  %-6s run %s: capture->publish p50 %.1f ms, p99 %.1f ms, max %.1f ms; receipt->publish p50 %.1f, p99 %.1f ms; %d poses, %d dropped, %d seq gaps (%d of %d frames processed); rival real-time CPU %.1f s\n", $1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13 }'
  done
done

echo
echo "== per mode (medians over runs; capture->publish = replay stamp on the daemon clock)"
awk -F, -v goal="$goal_p99_ms" '
  function median(s,   a, n, i, j, t) {
    n = split(s, a, " ")
    for (i = 1; i <= n; i++) for (j = i + 1; j <= n; j++) if (a[j] + 0 < a[i] + 0) { t = a[i]; a[i] = a[j]; a[j] = t }
    return n % 2 ? a[(n + 1) / 2] : (a[n / 2] + a[n / 2 + 1]) / 2
  }
  NR > 1 {
    if (!($1 in seen)) { seen[$1] = 1; order[++nm] = $1 }
    p50[$1] = p50[$1] " " $3; p99[$1] = p99[$1] " " $4; worst[$1] = ($4 > worst[$1] ? $4 : worst[$1])
    drop[$1] += ($9 > $10 ? $9 : $10); runs[$1]++  # counters and seq gaps see the same drops
    if ($4 > goal || $9 + $10 > 0) miss[$1]++
  }
  END {
    fail = 0
    for (k = 1; k <= nm; k++) {
      m = order[k]
      printf "%-6s %d runs: p50 %.1f ms, p99 median %.1f ms (worst run %.1f), dropped %d\n", m, runs[m], median(p50[m]), median(p99[m]), worst[m], drop[m]
      if (miss[m] > 0) fail = 1
      printf "%s %s: p99 <= %g ms and 0 dropped in every run (%d of %d runs met it)\n", (miss[m] > 0 ? "FAIL" : "PASS"), m, goal, runs[m] - miss[m], runs[m]
    }
    exit fail
  }' "$summary" && verdict=0 || verdict=1
echo "latency: per-run files in $work (summary.csv, <mode>-<run>/profile.txt, seaviod.log)"
exit $verdict
