#!/usr/bin/env bash
# One stage of `make demo` and `make test`: run a command with its output in a log file and print
# one line: the stage's wall and CPU time and the command's last line of output; on failure, the
# log's tail. With --show the output is also printed as it comes (the test suite's). Each stage
# appends "label<TAB>wall_s<TAB>cpu_s<TAB>exit" to build/logs/stages.tsv (read by
# bench/fresh_clone.py).
#
#   scripts/stage.sh [--show] LABEL COMMAND [ARG ...]
set -uo pipefail
show=0
if [ "${1:-}" = "--show" ]; then show=1; shift; fi
label=$1; shift
logdir=build/logs
mkdir -p "$logdir"
log="$logdir/$(printf '%s' "$label" | tr -c 'A-Za-z0-9_-' '_').log"
TIMEFORMAT='%R %U %S'
if [ "$show" = 1 ]; then
  { time "$@" 2>&1 | tee "$log"; } 2>"$log.time"
else
  { time "$@" >"$log" 2>&1; } 2>"$log.time"
fi
rc=$?
read -r wall user sys < <(tail -n 1 "$log.time")
rm -f "$log.time"
cpu=$(awk -v u="$user" -v s="$sys" 'BEGIN { printf "%.1f", u + s }')
printf '%s\t%s\t%s\t%s\n' "$label" "$wall" "$cpu" "$rc" >>"$logdir/stages.tsv"
last=$(grep -v '^[[:space:]]*$' "$log" | tail -n 1 | cut -c1-90)
if [ "$rc" -eq 0 ]; then
  printf '%-16s %6.1f s wall %6.1f s CPU  %s\n' "$label" "$wall" "$cpu" "$last"
else
  printf '%-16s FAILED (exit %s) after %.1f s; full log: %s\n' "$label" "$rc" "$wall" "$log"
  [ "$show" = 1 ] || tail -n 40 "$log" | sed 's/^/    /'
  exit "$rc"
fi
