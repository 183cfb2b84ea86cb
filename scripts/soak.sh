#!/usr/bin/env bash
# Soak test of seaviod (issue 7): a simulated survey, converted to an LCM log, is played in
# real time (looped and re-stamped by `seavio log --play --loop-s`) over UDP multicast into a
# running seaviod for N minutes, while lcm-logger records its poses and status. The daemon's
# RSS is sampled every 10 s. At the end: RSS start/end/slope per hour, and latency p50/p99
# of the first and last 5 minutes (`seavio profile --from-s/--to-s` on the recorded log).
#
# Everything runs in a private network namespace (unshare -rn), so multicast stays on that
# namespace's loopback and parallel runs do not collide.
#
# usage: scripts/soak.sh [MINUTES] [--valgrind | --lsan] [--build DIR] [--work DIR]
#                        [--frames N] [--keep]
#   MINUTES     run length (default 30)
#   --valgrind  run seaviod under valgrind memcheck (much slower than real time: frames drop)
#   --lsan      run seaviod with the LeakSanitizer runtime preloaded (leaks reported at exit)
#   --build     build folder holding bin/seavio and bin/seaviod (default: build)
#   --work      scratch folder (default: a new /tmp/seavio_soak.XXXXXX); the simulated
#               survey and its log are reused if already there
#   --frames    length of the simulated survey before it loops (default 600 = 40 s at 15 fps)
#   --keep      keep the scratch folder
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
minutes=30
mode=plain
build="$here/build"
work=""
frames=600
keep=0
while [[ $# -gt 0 ]]; do
  case "$1" in
    --valgrind) mode=valgrind ;;
    --lsan) mode=lsan ;;
    --build) build="$(cd "$2" && pwd)"; shift ;;
    --work) work="$2"; shift ;;
    --frames) frames="$2"; shift ;;
    --keep) keep=1 ;;
    -h|--help) sed -n '2,24p' "$0"; exit 0 ;;
    [0-9]*) minutes="$1" ;;
    *) echo "soak.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
  shift
done
[[ "$minutes" =~ ^[0-9]+([.][0-9]+)?$ ]] || { echo "soak.sh: MINUTES must be a number, got '$minutes'" >&2; exit 2; }
seavio="$build/bin/seavio"
seaviod="$build/bin/seaviod"
for b in "$seavio" "$seaviod"; do
  [[ -x "$b" ]] || { echo "soak.sh: $b not built (cmake --build $build --target seavio seaviod)" >&2; exit 2; }
done
for t in lcm-logger unshare ip; do
  command -v "$t" >/dev/null || { echo "soak.sh: '$t' not found (scripts/setup.sh installs it)" >&2; exit 2; }
done
if [[ "$mode" == valgrind ]]; then command -v valgrind >/dev/null || { echo "soak.sh: valgrind not installed" >&2; exit 2; }; fi
lsan_lib=""
if [[ "$mode" == lsan ]]; then
  lsan_lib="$(ls /usr/lib/*-linux-gnu/liblsan.so.0 2>/dev/null | head -1 || true)"
  [[ -n "$lsan_lib" ]] || { echo "soak.sh: liblsan.so.0 not found (apt-get install liblsan0)" >&2; exit 2; }
fi

if [[ -z "$work" ]]; then
  work="$(mktemp -d /tmp/seavio_soak.XXXXXX)"
  [[ $keep == 1 ]] || trap 'rm -rf "$work"' EXIT
fi
mkdir -p "$work"
seconds=$(awk -v m="$minutes" 'BEGIN { printf "%d", m * 60 }')
echo "soak: $minutes min, mode $mode, work folder $work"

# 1. Survey and its log (reused when present).
if [[ ! -d "$work/seq/mav0" ]]; then
  echo "soak: simulating a $frames-frame survey"
  "$seavio" simulate short-plain --frames "$frames" --frame-rate 15 --seed 5 --force --out "$work/seq" > "$work/simulate.log" 2>&1
fi
if [[ ! -f "$work/survey.lcmlog" ]]; then
  "$seavio" log --dataset "$work/seq" --out "$work/survey.lcmlog"
fi

# 2. Daemon config: LCM in, LCM out, live settings (never blocks acquisition).
url="udpm://239.255.76.67:7667?ttl=0&recv_buf_size=16777216"
cat > "$work/soak.yaml" <<EOF
daemon:
  processor: odometry
  calibration_dataset: "$work/seq"
  camera: {driver: lcm}
  imu: {driver: lcm}
  drain_to_newest: false
  status_period_ms: 1000
  lcm: {url: "$url"}
EOF

case "$mode" in
  valgrind) launcher="valgrind --tool=memcheck --leak-check=full --error-exitcode=0 --log-file=$work/valgrind.log" ;;
  lsan) launcher="env LD_PRELOAD=$lsan_lib LSAN_OPTIONS=log_path=$work/lsan" ;;
  *) launcher="" ;;
esac

# 3. The run, inside a private network namespace.
export SOAK_WORK="$work" SOAK_URL="$url" SOAK_SECONDS="$seconds" SOAK_SEAVIO="$seavio" SOAK_SEAVIOD="$seaviod"
export SOAK_LAUNCHER="$launcher"
unshare -rn bash -c '
set -euo pipefail
ip link set lo up
ip route add 224.0.0.0/4 dev lo
w="$SOAK_WORK"
lcm-logger --lcm-url="$SOAK_URL" -c "SEAVIO_POSE|SEAVIO_STATUS" --force "$w/out.lcmlog" > "$w/logger.log" 2>&1 &
logger=$!
$SOAK_LAUNCHER "$SOAK_SEAVIOD" --config "$w/soak.yaml" > "$w/seaviod.log" 2>&1 &
daemon=$!
sleep 3
kill -0 $daemon 2>/dev/null || { echo "soak: seaviod exited at start:"; cat "$w/seaviod.log"; exit 2; }
# valgrind and env exec in place: $daemon is the seaviod process itself.
pid=$daemon
echo "t_s,rss_kb" > "$w/rss.csv"
start=$(date +%s)
(
  while kill -0 $pid 2>/dev/null; do
    echo "$(( $(date +%s) - start )),$(awk "/^VmRSS/ {print \$2}" /proc/$pid/status 2>/dev/null || echo 0)" >> "$w/rss.csv"
    sleep 10
  done
) &
sampler=$!
"$SOAK_SEAVIO" log --play "$w/survey.lcmlog" --url "$SOAK_URL" --speed 1 --loop-s "$SOAK_SECONDS" > "$w/play.log" 2>&1 || true
sleep 3  # the last frames leave the pipeline
echo "$(( $(date +%s) - start )),$(awk "/^VmRSS/ {print \$2}" /proc/$pid/status 2>/dev/null || echo 0)" >> "$w/rss.csv"
kill $sampler 2>/dev/null || true
kill -TERM $daemon
wait $daemon || echo "soak: seaviod exit status $?"
kill -INT $logger
wait $logger || true
'

# 4. Figures.
echo
echo "== player"; cat "$work/play.log"
echo "== seaviod summary at exit"; sed -n '/seaviod health/,$p' "$work/seaviod.log" | tail -n 30
echo "== RSS (every 10 s: $work/rss.csv)"
awk -F, 'NR > 1 && $2 > 0 { n++; x[n] = $1; y[n] = $2 }
  END {
    if (n < 2) { print "too few RSS samples"; exit }
    # Slope by least squares, skipping the first minute (start-up allocations).
    for (i = 1; i <= n; i++) late += (x[i] >= 60)
    skip = late >= 6 ? 60 : -1  # too short a run: fit every sample
    for (i = 1; i <= n; i++) {
      if (y[i] > top) top = y[i]
      if (x[i] >= skip) { m++; sx += x[i]; sy += y[i]; sxx += x[i] * x[i]; sxy += x[i] * y[i] }
    }
    slope = (m > 1 && m * sxx - sx * sx > 0) ? (m * sxy - sx * sy) / (m * sxx - sx * sx) : 0
    printf "RSS start %.1f MB, end %.1f MB, max %.1f MB; slope %+.2f MB/h (least squares over %d of %d samples%s)\n",
      y[1] / 1024, y[n] / 1024, top / 1024, slope * 3600 / 1024, m, n, (skip > 0 ? ", first minute skipped" : "")
  }' "$work/rss.csv"
window=300
if (( seconds < 2 * window )); then window=$(( seconds / 2 )); fi
echo "== latency, first $window s"
"$seavio" profile "$work/out.lcmlog" --to-s "$window" --plot "$work/first.png" | sed -n '1,40p'
last_from=$(( seconds - window ))
echo "== latency, last $window s (from $last_from s)"
"$seavio" profile "$work/out.lcmlog" --from-s "$last_from" --plot "$work/last.png" | sed -n '1,40p'
if [[ "$mode" == valgrind ]]; then echo "== valgrind"; grep -E "definitely|indirectly|ERROR SUMMARY" "$work/valgrind.log" || true; fi
if [[ "$mode" == lsan ]]; then echo "== LeakSanitizer"; cat "$work"/lsan* 2>/dev/null || echo "no leak reported"; fi
echo "soak: files in $work"
