# shellcheck shell=bash
# Helpers shared by scripts/soak.sh and scripts/latency.sh, which both replay a simulated
# survey over LCM into seaviod inside a private network namespace and judge its latency.
# Sourced, never run; every function is prefixed `seavio_` and sets no global state but the
# variables it documents. Also sourced inside the namespaced `bash -c` of each script (the
# path is exported as SEAVIO_DAEMON_RUN_LIB), so the sampler there uses the same code.

SEAVIO_SCRIPTS_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
# Multicast stays on the namespace's loopback; the large receive buffer keeps 640 x 480
# stereo frames from being dropped by the kernel when a reader is late.
# shellcheck disable=SC2034  # read by the scripts that source this
SEAVIO_LCM_URL="udpm://239.255.76.67:7667?ttl=0&recv_buf_size=16777216"
export SEAVIO_DAEMON_RUN_LIB="${BASH_SOURCE[0]}"

# seavio_need_bins SCRIPT BUILD: exits 2 unless BUILD/bin/seavio and BUILD/bin/seaviod exist.
seavio_need_bins() {
  local b
  for b in "$2/bin/seavio" "$2/bin/seaviod"; do
    [[ -x "$b" ]] || { echo "$1: $b not built (cmake --build $2 --target seavio seaviod)" >&2; exit 2; }
  done
}

# seavio_need_tools SCRIPT TOOL...: exits 2 naming the first TOOL not on PATH.
seavio_need_tools() {
  local s="$1" t
  shift
  for t in "$@"; do
    command -v "$t" >/dev/null || { echo "$s: '$t' not found (scripts/setup.sh installs it)" >&2; exit 2; }
  done
}

# seavio_survey_log SEAVIO WORK FRAMES SEED: a FRAMES-frame 640 x 480 15 fps short-plain
# survey in WORK/seq and its LCM log WORK/survey.lcmlog, each made only when absent (a kept
# --work folder is reused).
seavio_survey_log() {
  if [[ ! -d "$2/seq/mav0" ]]; then
    echo "simulating a $3-frame 640 x 480 15 fps survey (short-plain seed $4)"
    "$1" simulate short-plain --frames "$3" --frame-rate 15 --seed "$4" --force --out "$2/seq" > "$2/simulate.log" 2>&1
  fi
  [[ -f "$2/survey.lcmlog" ]] || "$1" log --dataset "$2/seq" --out "$2/survey.lcmlog"
}

# seavio_ns_multicast: inside a fresh network namespace, brings loopback up and routes
# multicast over it.
seavio_ns_multicast() {
  ip link set lo up
  ip route add 224.0.0.0/4 dev lo
}

# seavio_rival_cpu STATE MIN_PRIO "PID PID ..." [NOW]: CPU time [s] used since the previous
# call with the same STATE file by other processes' real-time threads at priority MIN_PRIO
# or above (the PIDs excluded: ours), see scripts/rival_cpu.awk; NOW (/proc/uptime seconds)
# defaults to the current time.
seavio_rival_cpu() {
  local now="${4:-$(cut -d' ' -f1 /proc/uptime)}"
  { grep -H "" /proc/[0-9]*/task/*/stat 2>/dev/null || true; } |
    awk -v state="$1" -v min="$2" -v hz="$(getconf CLK_TCK)" -v now="$now" -v excl=" $3 " \
        -f "$SEAVIO_SCRIPTS_DIR/rival_cpu.awk"
}

# seavio_jstat FILE NAME FIELD: FIELD of the per-frame statistics NAME in a
# `seavio profile --json` file (empty if absent).
seavio_jstat() {
  grep -o "\"name\": \"$2\"[^}]*" "$1" 2>/dev/null | head -1 | sed -E "s/.*\"$3\": ([^,}]+).*/\1/"
}

# seavio_exit_counter LOG TEXT: the number after TEXT in seaviod's exit summary in LOG (0 if
# absent).
seavio_exit_counter() {
  local v
  v=$(sed -n '/seaviod health/,$p' "$1" | grep -oE "$2 [0-9]+" | head -1 | grep -oE '[0-9]+$' || true)
  echo "${v:-0}"
}
