#!/usr/bin/env bash
# Samples a running mapdelta-server's memory beside a load run: every S seconds (default 5) one
# line "t_s rss_mib in_use_mib free_held_mib mmapped_mib" from /proc/PID/status (VmRSS) and the
# glibc heap gauges of its /metrics (mapdelta_heap_bytes). RSS far above in_use is memory malloc
# keeps in its arenas (fragmentation, per-thread arenas); in_use is data the server holds.
# Stops when the process is gone.   Usage: bash bench/heap_poll.sh PID PORT [S]
set -uo pipefail
pid=$1 port=$2 every=${3:-5}
t0=$(date +%s)
while kill -0 "$pid" 2>/dev/null; do
  rss=$(awk '/^VmRSS:/ {print $2}' "/proc/$pid/status" 2>/dev/null)
  heap=$(curl -s --max-time 20 "http://127.0.0.1:$port/metrics" | awk '
    /^mapdelta_heap_bytes\{kind="in_use"\}/ {u = $2}
    /^mapdelta_heap_bytes\{kind="free_held"\}/ {f = $2}
    /^mapdelta_heap_bytes\{kind="mmapped"\}/ {m = $2}
    END {printf "%.0f %.0f %.0f", u / 1048576, f / 1048576, m / 1048576}')
  [ -n "$rss" ] && echo "$(($(date +%s) - t0)) $((rss / 1024)) $heap"
  sleep "$every"
done
