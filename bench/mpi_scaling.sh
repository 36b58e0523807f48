#!/bin/sh
# mpi_scaling.sh: data-parallel training on this machine (docs/scaling.md): 1 rank x 2 threads
# against 2 ranks x 1 thread, at 128 and 256 px, the same global batch and micro-batch, time per
# iteration and the share of it spent in MPI_Allreduce (rank 0's count).
# usage: bench/mpi_scaling.sh [HDNET] [ITERS] [WIDTH]   (defaults: ./hdnet 6 48)
set -eu
hdnet=$(cd "$(dirname "${1:-./hdnet}")" && pwd)/$(basename "${1:-./hdnet}")
iters=${2:-6}
width=${3:-48}
work=$(mktemp -d "${TMPDIR:-/tmp}/hdnet-mpi-bench.XXXXXX")
trap 'rm -rf "$work"' EXIT
cd "$work"
echo "| size | ranks x threads | batch | s per iteration | allreduce share |"
echo "|---|---|---|---|---|"
for size in 128 256; do
    "$hdnet" synth data$size --subjects 4 --per-subject 2 --size $size --seed 9 >/dev/null 2>&1
    common="train data$size --size $size --width $width --batch 2 --micro-batch 1 --every 100000 -q"
    # iteration 1 warms up (plans, pages): time iterations 2..ITERS from the loss.csv clock
    "$hdnet" $common --threads 2 --iters "$iters" -o one$size >/dev/null 2>one$size.log
    t1=$(awk -F, -v n="$iters" 'NR==2{a=$NF} NR==n+1{b=$NF} END{printf "%.3f", (b-a)/(n-1)}' one$size/loss.csv)
    echo "| $size | 1 x 2 | 2 | $t1 | - |"
    mpirun --allow-run-as-root --oversubscribe -np 2 "$hdnet" $common --threads 1 --iters "$iters" -o two$size >/dev/null 2>two$size.log
    t2=$(awk -F, -v n="$iters" 'NR==2{a=$NF} NR==n+1{b=$NF} END{printf "%.3f", (b-a)/(n-1)}' two$size/loss.csv)
    share=$(sed -n 's/.*steps in \([0-9.]*\) s .*, \([0-9.]*\) s of it in MPI_Allreduce.*/\2 \1/p' two$size.log |
            awk '{printf "%.1f %%", 100 * $1 / $2}')
    echo "| $size | 2 x 1 | 2 | $t2 | $share |"
done
