#!/bin/sh
# mpi_batch.sh: a batch command over a folder on this machine (docs/scaling.md, "Inference"):
# 1 rank x 2 threads against 2 ranks x 1 thread, each run ROUNDS times in turn (the machine is
# shared: the load average is printed beside every figure). photos/s is the job's summary
# (photos over the loop's wall time on rank 0, model loads excluded); wall s is the whole
# command, model and aligner loads included.
# usage: bench/mpi_batch.sh HDNET PHOTOS_DIR [ROUNDS] [COMMAND ARGS...]
#        (defaults: 2 rounds of relight --preset 3)
set -eu
hdnet=$(cd "$(dirname "$1")" && pwd)/$(basename "$1")
photos=$(cd "$2" && pwd)
rounds=${3:-2}
shift 2; [ $# -eq 0 ] || shift
[ $# -gt 0 ] || set -- relight --preset 3
work=$(mktemp -d "${TMPDIR:-/tmp}/hdnet-mpi-batch.XXXXXX")
trap 'rm -rf "$work"' EXIT
cd "$work"
echo "| ranks x threads | photos | photos/s | wall s | load average (1 min) before |"
echo "|---|---|---|---|---|"
for r in $(seq "$rounds"); do
    for cfg in "1 2" "2 1"; do
        ranks=${cfg% *}; threads=${cfg#* }
        load=$(cut -d' ' -f1 /proc/loadavg)
        rm -rf out
        t0=$(date +%s.%N)
        if [ "$ranks" -eq 1 ]; then
            "$hdnet" "$@" "$photos" -o out -j "$threads" > run.log 2>&1 || true
        else
            mpirun --allow-run-as-root --oversubscribe -np "$ranks" "$hdnet" "$@" "$photos" -o out -j "$threads" > run.log 2>&1 || true
        fi
        t1=$(date +%s.%N)
        line=$(grep ' photos -> out: ' run.log || { cat run.log >&2; exit 1; })
        n=$(echo "$line" | sed -n 's/^[a-z-]*: \([0-9]*\) photos.*/\1/p')
        rate=$(echo "$line" | sed -n 's/.*, \([0-9.]*\) photos\/s$/\1/p')
        echo "| $ranks x $threads | $n | $rate | $(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.1f", b - a }') | $load |"
    done
done
