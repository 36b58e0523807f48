#!/bin/sh
# serve_load.sh: the load test of `hdnet serve` (make load-test): on loopback, 4 clients (wrk, one
# connection each) relight the bundled photo for LOAD_SECONDS (30) seconds, cycling through the
# presets. Fails on any non-2xx answer or socket error, or if the server's resident memory grows
# by more than 16 MB between the end of the first third of the run and its end (the model's working
# memory is allocated by the first requests). Prints requests per second and latency percentiles
# (docs/performance.md, "hdnet serve"). Bounded: wrk stops itself; the server is stopped at the end.
set -u
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
HDNET=${HDNET:?HDNET must point at the hdnet tool}
seconds=${LOAD_SECONDS:-30}
fail() { echo "serve_load: FAILED: $*" >&2; exit 1; }
command -v wrk >/dev/null 2>&1 || fail "wrk is not installed (apt-get install wrk)"
command -v curl >/dev/null 2>&1 || fail "curl is not installed (apt-get install curl)"
scratch=$(mktemp -d "${TMPDIR:-/tmp}/hdnet-load.XXXXXX")
"$HDNET" serve --port 0 ${LOAD_THREADS:+--threads "$LOAD_THREADS"} >"$scratch/serve.log" 2>&1 &
pid=$!
trap 'kill $pid 2>/dev/null; rm -rf "$scratch"' EXIT
i=0
until grep -q 'listening on' "$scratch/serve.log"; do
    i=$((i + 1))
    [ $i -le 600 ] && kill -0 $pid 2>/dev/null || { cat "$scratch/serve.log" >&2; fail "the server did not start"; }
    sleep 0.1
done
port=$(sed -n 's|.*http://127\.0\.0\.1:\([0-9]*\)/.*|\1|p' "$scratch/serve.log")
base="http://127.0.0.1:$port"
curl -s -m 120 -o "$scratch/up.json" -H 'Content-Type: image/png' --data-binary @"$root/examples/astronaut.png" \
    "$base/api/photos" || fail "upload failed"
id=$(sed -n 's/^{"id":"\([0-9a-f]*\)".*/\1/p' "$scratch/up.json")
[ -n "$id" ] || fail "no photo id in $(head -c 200 "$scratch/up.json")"

rss() { awk '/^VmRSS:/ {print $2}' /proc/$pid/status; } # kB
# the server's user + system CPU time in clock ticks (fields 14 and 15 of /proc/PID/stat; the
# command name, field 2, has no spaces here)
cpu_ticks() { awk '{print $14 + $15}' /proc/$pid/stat; }
ticks0=$(cpu_ticks)
(
    t=0
    while [ $t -lt "$seconds" ]; do
        sleep 1
        t=$((t + 1))
        echo "$t $(rss)"
    done
) >"$scratch/rss.txt" &
sampler=$!
wrk -t4 -c4 -d"${seconds}s" --timeout 60s --latency -s "$here/relight.lua" "$base/api/photos/$id/relight" \
    >"$scratch/wrk.txt" 2>&1
wait $sampler
ticks1=$(cpu_ticks)
cat "$scratch/wrk.txt"
figures=$(grep '^figures:' "$scratch/wrk.txt") || fail "wrk printed no figures"
early=$(awk -v t=$((seconds / 3)) '$1 == t {print $2}' "$scratch/rss.txt")
late=$(tail -n 1 "$scratch/rss.txt" | awk '{print $2}')
peak=$(awk 'BEGIN {m = 0} $2 > m {m = $2} END {print m}' "$scratch/rss.txt")
echo "resident memory: $early kB at ${early:+$((seconds / 3))} s, $late kB at the end, peak $peak kB"
set -- $figures
requests=$3 non2xx=${17} socket=${19}
[ "$requests" -gt 0 ] || fail "no request completed"
hz=$(getconf CLK_TCK)
awk -v t=$((ticks1 - ticks0)) -v hz="$hz" -v n="$requests" -v s="$seconds" \
    'BEGIN {printf "server CPU: %.1f s in %d s (%.2f cores), %.3f CPU-seconds a relight\n", t / hz, s, t / hz / s, t / hz / n}'
[ "$non2xx" -eq 0 ] || fail "$non2xx answers were not 2xx"
[ "$socket" -eq 0 ] || fail "$socket socket errors"
[ $((late - early)) -le 16384 ] || fail "resident memory grew by $((late - early)) kB (from $early to $late kB)"
kill -INT $pid
wait $pid || fail "the server did not stop cleanly"
trap 'rm -rf "$scratch"' EXIT
echo "serve_load: ok: $requests relights in ${seconds} s by 4 clients, no error, memory flat"
