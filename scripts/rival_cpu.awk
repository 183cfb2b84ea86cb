# rival_cpu.awk: CPU time [s] used, since the previous call, by the real-time threads
# (SCHED_FIFO/RR, user space) of processes other than ours at priority >= min: the threads
# that take the cores from a real-time daemon on a shared machine (scripts/soak.sh,
# scripts/latency.sh). Input: `grep -H '' /proc/[0-9]*/task/*/stat` (grep, unlike mawk, goes
# on past a thread that exited meanwhile). Variables: state (file keeping per-thread ticks
# between calls), min, hz (getconf CLK_TCK), now (monotonic seconds, /proc/uptime), excl
# (" pid pid ... ": our processes). The first call prints 0 (no previous ticks); a thread
# started since the previous call counts whole.
BEGIN { while ((getline l < state) > 0) { split(l, a, " "); if (a[1] == "t") t_prev = a[2]; else prev[a[1]] = a[2] } close(state) }
{
  c = index($0, ":"); split(substr($0, 1, c - 1), p, "/")  # /proc/PID/task/TID/stat
  if (index(excl, " " p[3] " ")) next
  r = substr($0, c + 1); sub(/^.*\) /, "", r); n = split(r, f, " ")
  if (n < 39) next
  # After "tid (comm) ", f[1] is field 3 of proc_pid_stat(5): field N is f[N - 2].
  if (int(f[7] / 2097152) % 2) next   # PF_KTHREAD: kernel threads (irq handlers) are no job
  if ((f[39] == 1 || f[39] == 2) && f[38] >= min) {
    tid = p[5]; t = f[12] + f[13]; cur[tid] = t
    if (tid in prev) d += t - prev[tid]
    else if (t_prev != "" && f[20] / hz >= t_prev) d += t   # started since the last sample
  }
}
END { print "t", now > state; for (k in cur) print k, cur[k] > state; printf "%.2f\n", d / hz }
