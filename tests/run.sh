#!/bin/sh
# run.sh: runs every C test binary given on the command line, then every tests/*.sh script (which
# drive the hdnet tool at $HDNET), each in its own scratch directory; runs them all, names each
# failure, ends with "N passed, N failed, N skipped" and exits nonzero if any failed (a script that
# cannot run here exits 77 through cli_common.shlib's skip, which fails it instead in CI). With
# TEST_SCRIPTS set (names such as "apply_cli", space-separated), only those shell scripts run: `make test-portable`
# runs the C tests and one CLI script on the portable build, whose shell scripts would only repeat
# the default build's (the tool is the same; the C tests hold the two convolution paths together).
#
# TEST_JOBS tests run at once (default: the number of processors, at most 4; 1 runs them one after
# another with their output as it comes). With more than one, each test's output is printed whole
# when it ends, after its PASS / FAIL line, and the slowest tests start first. Most tests spend much
# of their time in one thread (loading, writing, the shell): under `make check` on two cores the 49
# tests' own times added up to 33 min and the run took 19 (docs/performance.md). OpenMP's threads
# wait passively so that a test's idle threads do not spin on the other test's core.
#
# Usage: sh tests/run.sh [TEST_BINARY...]    (internally: sh tests/run.sh --one SCRATCH PATH)
set -u
here=$(cd "$(dirname "$0")" && pwd)

# --one SCRATCH PATH: runs one test (a binary, or a .sh script) in SCRATCH/NAME; writes its exit code
# to SCRATCH/NAME.rc and its time to SCRATCH/NAME.time; its output goes to SCRATCH/NAME.log unless
# the run is serial.
if [ "${1:-}" = "--one" ]; then
    scratch=$2 path=$3
    name=$(basename "$path" .sh)
    mkdir -p "$scratch/$name"
    start=$(date +%s)
    case $path in
    *.sh) set -- sh "$path" ;;
    *) set -- "$path" ;;
    esac
    if [ "${TEST_JOBS:-1}" -gt 1 ]; then
        (cd "$scratch/$name" && "$@") >"$scratch/$name.log" 2>&1
    else
        (cd "$scratch/$name" && "$@")
    fi
    rc=$?
    echo $(($(date +%s) - start)) >"$scratch/$name.time"
    echo $rc >"$scratch/$name.rc"
    # one test's lines together (under a lock when tests run at once): its result, then what it
    # printed if that was kept
    {
        flock 9 2>/dev/null
        case $rc in
        0) echo "PASS $name ($(cat "$scratch/$name.time")s)" ;;
        77) ;; # the script printed its SKIP line
        *) echo "FAIL $name (exit $rc)" ;;
        esac
        [ ! -f "$scratch/$name.log" ] || sed 's/^/    /' "$scratch/$name.log"
    } 9>>"$scratch/.print-lock"
    exit 0
fi

scratch=$(mktemp -d "${TMPDIR:-/tmp}/hdnet-test.XXXXXX")
trap 'rm -rf "$scratch"' EXIT
export HDNET_TESTDATA="$here/data"
if [ -z "${TEST_JOBS:-}" ]; then
    TEST_JOBS=$(nproc 2>/dev/null || echo 1)
    [ "$TEST_JOBS" -le 4 ] || TEST_JOBS=4
fi
case $TEST_JOBS in '' | *[!0-9]* | 0) echo "run.sh: TEST_JOBS must be a positive number (is '$TEST_JOBS')"; exit 1 ;; esac
export TEST_JOBS
[ "$TEST_JOBS" -gt 1 ] && export OMP_WAIT_POLICY=passive

scripts=""
if [ -n "${TEST_SCRIPTS:-}" ]; then
    for n in $TEST_SCRIPTS; do
        [ -f "$here/$n.sh" ] || { echo "run.sh: no test script tests/$n.sh (TEST_SCRIPTS)"; exit 1; }
        scripts="$scripts $here/$n.sh"
    done
else
    scripts=$(ls "$here"/*.sh)
fi
# The list, one path a line: the binaries, then the scripts (run.sh itself left out).
list=$scratch/.list
: >"$list"
for t in "$@" $scripts; do
    [ "$t" = "$here/run.sh" ] && continue
    [ -f "$t" ] || continue
    echo "$t" >>"$list"
done
if [ "$TEST_JOBS" -gt 1 ]; then
    # the slowest first (as measured under make check), so that the last to end is a short one
    slow="relight_eval_cli test_threads serve_api multilight_cli python photo_cli test_video train_cli video_cli apply_cli test_face_detect cli_batch"
    ordered=$scratch/.ordered
    : >"$ordered"
    for s in $slow; do grep -E "/$s(\.sh)?\$" "$list" >>"$ordered"; done
    grep -v -F -x -f "$ordered" "$list" >>"$ordered"
    list=$ordered
fi
# install.sh runs `make install`, which relinks the tool and the libraries the other tests are
# running (the install prefix is compiled in): it runs alone, after the others.
alone=$(grep -E '/install\.sh$' "$list")
grep -v -E '/install\.sh$' "$list" | tr '\n' '\0' | xargs -0 -r -P "$TEST_JOBS" -n 1 sh "$here/run.sh" --one "$scratch"
for t in $alone; do sh "$here/run.sh" --one "$scratch" "$t"; done

pass=0
failed=""
skipped=""
while read -r t; do
    name=$(basename "$t" .sh)
    rc=$(cat "$scratch/$name.rc" 2>/dev/null || echo 1)
    if [ "$rc" -eq 0 ]; then
        pass=$((pass + 1))
    elif [ "$rc" -eq 77 ]; then
        skipped="$skipped $name"
    else
        failed="$failed $name"
    fi
done <"$list"
nfail=$(echo $failed | wc -w)
nskip=$(echo $skipped | wc -w)
[ "$nfail" -eq 0 ] || echo "failed:$failed"
[ "$nskip" -eq 0 ] || echo "skipped (not run here, see each SKIP line):$skipped"
echo "$pass passed, $nfail failed, $nskip skipped"
[ "$nfail" -eq 0 ]
