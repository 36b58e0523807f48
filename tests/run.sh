#!/bin/sh
# run.sh: runs every C test binary given on the command line, then every tests/*.sh script (which
# drive the hdnet tool at $HDNET), each in its own scratch directory; runs them all, names each
# failure, ends with "N passed, N failed, N skipped" and exits nonzero if any failed (a script that
# cannot run here exits 77 through cli_common.shlib's skip, which fails it instead in CI). With
# TEST_SCRIPTS set (names such as "apply_cli", space-separated), only those shell scripts run: `make test-portable`
# runs the C tests and one CLI script on the portable build, whose shell scripts would only repeat
# the default build's (the tool is the same; the C tests hold the two convolution paths together).
set -u
here=$(cd "$(dirname "$0")" && pwd)
scratch=$(mktemp -d "${TMPDIR:-/tmp}/hdnet-test.XXXXXX")
trap 'rm -rf "$scratch"' EXIT
export HDNET_TESTDATA="$here/data"
pass=0
failed=""
skipped=""

# run NAME COMMAND...: runs one test in scratch/NAME and counts it.
run() {
    name=$1
    shift
    start=$(date +%s)
    mkdir -p "$scratch/$name"
    (cd "$scratch/$name" && "$@")
    rc=$?
    if [ $rc -eq 0 ]; then
        echo "PASS $name ($(( $(date +%s) - start ))s)"
        pass=$((pass + 1))
    elif [ $rc -eq 77 ]; then
        skipped="$skipped $name"
    else
        echo "FAIL $name"
        failed="$failed $name"
    fi
}

for t in "$@"; do
    run "$(basename "$t")" "$t"
done
scripts=""
if [ -n "${TEST_SCRIPTS:-}" ]; then
    for n in $TEST_SCRIPTS; do
        [ -f "$here/$n.sh" ] || { echo "run.sh: no test script tests/$n.sh (TEST_SCRIPTS)"; exit 1; }
        scripts="$scripts $here/$n.sh"
    done
else
    scripts=$(ls "$here"/*.sh)
fi
for t in $scripts; do
    [ "$t" = "$here/run.sh" ] && continue
    [ -f "$t" ] || continue
    run "$(basename "$t" .sh)" sh "$t"
done
nfail=$(echo $failed | wc -w)
nskip=$(echo $skipped | wc -w)
[ "$nfail" -eq 0 ] || echo "failed:$failed"
[ "$nskip" -eq 0 ] || echo "skipped (not run here, see each SKIP line):$skipped"
echo "$pass passed, $nfail failed, $nskip skipped"
[ "$nfail" -eq 0 ]
