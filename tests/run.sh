#!/bin/sh
# run.sh: runs every C test binary given on the command line, then every tests/*.sh script (which
# drive the hdnet tool at $HDNET), each in a scratch directory; stops at the first failure.
set -u
here=$(cd "$(dirname "$0")" && pwd)
scratch=$(mktemp -d "${TMPDIR:-/tmp}/hdnet-test.XXXXXX")
trap 'rm -rf "$scratch"' EXIT
export HDNET_TESTDATA="$here/data"
pass=0
for t in "$@"; do
    name=$(basename "$t")
    start=$(date +%s)
    mkdir -p "$scratch/$name"
    if (cd "$scratch/$name" && "$t"); then
        echo "PASS $name ($(( $(date +%s) - start ))s)"
        pass=$((pass + 1))
    else
        echo "FAIL $name"
        exit 1
    fi
done
for t in "$here"/*.sh; do
    [ "$t" = "$here/run.sh" ] && continue
    [ -f "$t" ] || continue
    name=$(basename "$t" .sh)
    start=$(date +%s)
    mkdir -p "$scratch/$name"
    if (cd "$scratch/$name" && sh "$t"); then
        echo "PASS $name ($(( $(date +%s) - start ))s)"
        pass=$((pass + 1))
    else
        echo "FAIL $name"
        exit 1
    fi
done
echo "all $pass tests passed"
