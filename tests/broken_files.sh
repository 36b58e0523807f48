#!/bin/sh
# broken_files.sh: every file of tests/data/broken/ (made by tests/data/make_broken.py) must be
# refused by `hdnet info` with exit status 1 or 2 (never 0, never a signal: status >= 128) and one
# line on stderr, `hdnet info: <reason>`, that names the file and holds no raw control byte
# (input's bytes below 0x20 and 0x7f are printed escaped, \x1b). Under `make check` a sanitizer
# report also exits 1, so any sanitizer output counts as a failure too.
set -u
data=${HDNET_TESTDATA:?HDNET_TESTDATA is not set}/broken
hdnet=${HDNET:?HDNET is not set}
count=0
failures=0
for f in "$data"/*; do
    [ -f "$f" ] || continue
    name=$(basename "$f")
    count=$((count + 1))
    "$hdnet" info "$f" >stdout.txt 2>stderr.txt
    rc=$?
    problem=""
    if [ "$rc" -eq 0 ]; then
        problem="accepted (exit 0)"
    elif [ "$rc" -ge 128 ]; then
        problem="killed by a signal (exit $rc)"
    elif [ "$rc" -ne 1 ] && [ "$rc" -ne 2 ]; then
        problem="exit status $rc"
    elif grep -q -e 'Sanitizer' -e 'runtime error' stderr.txt; then
        problem="sanitizer report"
    elif ! grep -q "^hdnet info: .*$name" stderr.txt; then
        problem="the message does not name the file"
    elif [ "$(wc -l <stderr.txt)" -ne 1 ]; then
        problem="more than one line on stderr"
    elif tr -d '\n' <stderr.txt | LC_ALL=C grep -q '[[:cntrl:]]'; then
        problem="a control byte of the file reached stderr raw (it must be escaped, \\x1b)"
    fi
    if [ -n "$problem" ]; then
        echo "broken_files: $name: $problem" >&2
        sed 's/^/    /' stderr.txt >&2
        failures=$((failures + 1))
    fi
done
if [ "$count" -lt 30 ]; then
    echo "broken_files: only $count files in $data (at least 30 expected)" >&2
    exit 1
fi
# All at once: each is reported, the status is still 1.
"$hdnet" info "$data"/* >/dev/null 2>all.txt
rc=$?
if [ "$rc" -ne 1 ] || [ "$(grep -c '^hdnet info: ' all.txt)" -ne "$count" ]; then
    echo "broken_files: one run over all $count files gave status $rc and $(grep -c '^hdnet info: ' all.txt) reports" >&2
    failures=$((failures + 1))
fi
[ "$failures" -eq 0 ] || exit 1
echo "broken_files: $count broken files refused cleanly"
