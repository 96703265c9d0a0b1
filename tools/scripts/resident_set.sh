#!/usr/bin/env bash
# The resident set of a command while it runs: `tools/scripts/resident_set.sh COMMAND [ARGS...]`
# polls /proc/PID/status every 0.3 s and prints the last VmRSS seen and the peak (VmHWM), in MiB.
# The command's output goes to $RESIDENT_LOG (default /tmp/resident_set.log). For the editor at
# rest on its default scene: `xvfb-run -a -s "-screen 0 1600x1000x24" tools/scripts/resident_set.sh
# $CARGO_TARGET_DIR/debug/treelight --frames 200`.
set -u
if [ $# -eq 0 ]; then
    echo "usage: $0 COMMAND [ARGS...]" >&2
    exit 2
fi
"$@" >"${RESIDENT_LOG:-/tmp/resident_set.log}" 2>&1 &
pid=$!
last=0
peak=0
while kill -0 "$pid" 2>/dev/null; do
    r=$(awk '/^VmRSS/ {print $2}' "/proc/$pid/status" 2>/dev/null)
    h=$(awk '/^VmHWM/ {print $2}' "/proc/$pid/status" 2>/dev/null)
    [ -n "$r" ] && last=$r
    [ -n "$h" ] && peak=$h
    sleep 0.3
done
wait "$pid"
status=$?
echo "resident $((last / 1024)) MiB at the last look, peak $((peak / 1024)) MiB (exit $status)"
exit "$status"
