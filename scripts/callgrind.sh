#!/usr/bin/env bash
# Instruction counts (callgrind Ir) of the hot paths on fixed synthetic input, so a
# speed-up is visible on a loaded machine where wall-clock benchmarks wander. Each stage runs
# once in bench/hotpaths with instrumentation on only around the stage; one summary line per
# stage with its heap allocations (calls of malloc, calloc, realloc, posix_memalign,
# aligned_alloc, memalign: operator new and cv::fastMalloc end in these), then the top
# functions of each (callgrind_annotate).
#   scripts/callgrind.sh                     all stages: surf_detect surf_describe ransac icp rectify
#                                            rectify_cv frame frame2 (rectify: our remap of one
#                                            640x480 pair; rectify_cv: cv::remap, same maps)
#   scripts/callgrind.sh ransac icp          only these
#   scripts/callgrind.sh steady steady2      allocations and Ir per frame in steady state: the
#                                            frame (frame2) path over STEADY_FRAMES consecutive
#                                            frames (default 5) after STEADY_WARMUP (default 8)
# Environment: SEAVIO_BUILD_DIR (default build), SEAVIO_JOBS (default 2), OUT (default
# callgrind-results/), TOP (functions listed per stage, default 8).
set -euo pipefail
cd "$(dirname "$0")/.."
build=${SEAVIO_BUILD_DIR:-build}
jobs=${SEAVIO_JOBS:-2}
out=${OUT:-callgrind-results}
top=${TOP:-8}
command -v valgrind >/dev/null || { echo "callgrind.sh: valgrind not installed (apt-get install valgrind)" >&2; exit 1; }
stages=("$@")
[ ${#stages[@]} -gt 0 ] || stages=(surf_detect surf_describe ransac icp rectify rectify_cv frame frame2)
mkdir -p "$out"

cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" -j"$jobs" --target hotpaths >/dev/null

declare -A ir allocs
# Calls of the C allocators recorded in a callgrind file (names are compressed to "(id)" after
# their first use, so ids are resolved as they are defined).
count_allocs() {
  awk '
    function name_of(s,   id, rest) {
      if (match(s, /^\([0-9]+\)/)) {
        id = substr(s, RSTART, RLENGTH); rest = substr(s, RLENGTH + 2)
        if (rest != "") names[id] = rest
        return names[id]
      }
      return s
    }
    /^c?fn=/ { n = name_of(substr($0, index($0, "=") + 1)); if ($0 ~ /^cfn=/) callee = n; next }
    /^calls=/ { if (callee ~ /^(malloc|calloc|realloc|posix_memalign|aligned_alloc|memalign)$/) { split(substr($0, 7), a, " "); total += a[1] } }
    END { print total + 0 }' "$1"
}
steady_stages=()
plain_stages=()
for s in "${stages[@]}"; do
  case "$s" in steady | steady2) steady_stages+=("$s") ;; *) plain_stages+=("$s") ;; esac
done
stages=("${plain_stages[@]+"${plain_stages[@]}"}")
# One callgrind dump per frame (hotpaths steady): name.1, name.2, ... in frame order.
for s in "${steady_stages[@]+"${steady_stages[@]}"}"; do
  f="$out/$s.callgrind"
  rm -f "$f" "$f".*
  valgrind --tool=callgrind --instr-atstart=no --callgrind-out-file="$f" "$build/bench/hotpaths" "$s" \
    "${STEADY_WARMUP:-8}" "${STEADY_FRAMES:-5}" 2>"$out/$s.log" | sed 's/^/  /'
  echo
  printf '%-8s %-10s %16s %8s\n' stage frame 'Ir' allocs
  for part in $(ls "$f".* 2>/dev/null | sed 's/.*\.//' | grep -E '^[0-9]+$' | sort -n); do
    pf="$f.$part"
    name=$(awk -F'"' '/^desc: Trigger:/ {print $2; exit}' "$pf" | sed 's/^frame //')
    [ -n "$name" ] || name=$(awk '/^desc: Trigger:/ {print $NF; exit}' "$pf")
    irs=$(awk '/^totals:/ {print $2}' "$pf")
    printf '%-8s %-10s %16s %8s\n' "$s" "$name" "$(printf "%'d" "$irs" 2>/dev/null || echo "$irs")" "$(count_allocs "$pf")"
  done
done

for s in "${stages[@]+"${stages[@]}"}"; do
  f="$out/$s.callgrind"
  valgrind --tool=callgrind --instr-atstart=no --callgrind-out-file="$f" "$build/bench/hotpaths" "$s" \
    2>"$out/$s.log" | sed 's/^/  /'
  ir[$s]=$(awk '/^totals:/ {print $2}' "$f")
  allocs[$s]=$(count_allocs "$f")
  # Function lines only (after the PROGRAM TOTALS line), names cut to 150 characters.
  callgrind_annotate --threshold=100 "$f" 2>/dev/null |
    awk -v top="$top" '/PROGRAM TOTALS/ {go = 1; next} go && /^ *[0-9,]+ / && n < top {print substr($0, 1, 150); n++}' \
      >"$out/$s.top"
done

[ ${#stages[@]} -gt 0 ] || exit 0
echo
printf '%-14s %16s %8s\n' stage 'Ir' allocs
for s in "${stages[@]}"; do
  printf '%-14s %16s %8s\n' "$s" "$(printf "%'d" "${ir[$s]}" 2>/dev/null || echo "${ir[$s]}")" "${allocs[$s]}"
done
for s in "${stages[@]}"; do
  echo
  echo "== $s: top $top functions (self Ir)"
  sed 's/^/  /' "$out/$s.top"
done
