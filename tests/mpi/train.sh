#!/bin/sh
# train.sh (make test-mpi): data-parallel `hdnet train` on Open MPI, on loopback, against the
# single-process run: 2, 3 and 4 ranks give the same weights, Adam moments and losses after 5
# iterations (bit for bit: the gradients are summed in double, tests/mpi/compare_runs.py allows
# 1e-5 relative), a run resumed on another rank count continues exactly, a signal to one rank
# stops all of them with a checkpoint, a rank killed makes the job fail instead of hanging, and a
# batch that does not divide among the ranks is refused. Needs mpirun and Debian's python3 with
# numpy; without them it fails naming what is missing (CI installs both).
set -eu
: "${HDNET:?HDNET must point at the hdnet binary}"
here=$(cd "$(dirname "$0")" && pwd)
py=/usr/bin/python3
for need in mpirun "$py"; do
    command -v "$need" >/dev/null 2>&1 || { echo "train.sh: $need is missing (apt-get install openmpi-bin python3-numpy)"; exit 1; }
done
"$py" -c 'import numpy' || { echo "train.sh: numpy is missing for $py (apt-get install python3-numpy)"; exit 1; }
mpi() { n=$1; shift; timeout 300 mpirun --allow-run-as-root --oversubscribe -np "$n" "$@"; }
same() { "$py" "$here/compare_runs.py" "$1" "$2" || { echo "FAIL: $2 differs from $1"; exit 1; }; }

"$HDNET" synth data --subjects 3 --per-subject 3 --size 32 --seed 5 >/dev/null 2>&1
T="$HDNET train data --size 32 --width 4 --batch 12 --micro-batch 1 --every 5 --seed 3 -q --threads 1"

$T --iters 5 -o one >/dev/null
for n in 2 3 4; do
    mpi "$n" $T --iters 5 -o "ranks$n" >/dev/null
    echo "$n ranks:"
    same one "ranks$n"
done

# only rank 0 writes the run folder: one loss.csv of 5 rows, one sample sheet
[ "$(wc -l < ranks2/loss.csv)" -eq 6 ] || { echo "FAIL: ranks2/loss.csv has $(wc -l < ranks2/loss.csv) lines"; exit 1; }

# resume on another rank count: 3 iterations on 2 ranks, then up to 5 on 3 ranks (and on 1)
mpi 2 $T --iters 3 -o resumed >/dev/null
mpi 3 $T --iters 5 --resume -o resumed >/dev/null
echo "2 ranks, resumed on 3:"
same one resumed
mpi 4 $T --iters 3 -o resumed1 >/dev/null
$T --iters 5 --resume -o resumed1 >/dev/null
echo "4 ranks, resumed alone:"
same one resumed1

# a batch that does not divide among the ranks
if mpi 2 $HDNET train data --size 32 --width 4 --batch 3 --micro-batch 1 --iters 2 -q -o bad > bad.log 2>&1; then
    echo "FAIL: a batch of 3 on 2 ranks was accepted"; exit 1
fi
grep -q "do not divide among 2 ranks\|does not divide among 2 ranks" bad.log || { echo "FAIL: no clear message:"; cat bad.log; exit 1; }

# a signal to one rank stops every rank at the same iteration, with rank 0's checkpoint
long="$T --iters 100000 --every 100000"
# signal_one_rank RUN LINES SIGNAL: starts a long 2-rank run into RUN, waits until loss.csv has
# LINES lines, sends SIGNAL to one rank and waits for the job; its exit status goes to $rc.
signal_one_rank() {
    mpi 2 $long -o "$1" > "$1.log" 2>&1 &
    job=$!
    i=0
    while [ ! -s "$1/loss.csv" ] || [ "$(wc -l < "$1/loss.csv")" -lt "$2" ]; do
        sleep 0.5; i=$((i + 1))
        [ $i -lt 400 ] || { echo "FAIL: the 2-rank run did not start"; kill $job; exit 1; }
    done
    kill "-$3" "$(pgrep -f "hdnet train data .*-o $1" | tail -1)"
    rc=0
    wait $job || rc=$?
}
signal_one_rank stopped 3 TERM
[ $rc -ne 0 ] || { echo "FAIL: a signalled run exited 0"; exit 1; }
grep -q '"iteration":"[0-9]*"' stopped/checkpoint.safetensors 2>/dev/null || strings stopped/checkpoint.safetensors | grep -q iteration \
    || { echo "FAIL: no checkpoint after the signal"; cat stopped.log; exit 1; }
rows=$(($(wc -l < stopped/loss.csv) - 1))
it=$("$py" -c "import json,struct,sys; f=open('stopped/checkpoint.safetensors','rb'); n=struct.unpack('<Q',f.read(8))[0]; print(json.loads(f.read(n))['__metadata__']['iteration'])")
[ "$it" -eq "$rows" ] || { echo "FAIL: checkpoint at iteration $it, loss.csv has $rows rows"; exit 1; }
echo "a signal to one rank: both stopped at iteration $it with a checkpoint"
# and the stopped run resumes
mpi 2 $T --iters $((it + 2)) --resume -o stopped >/dev/null

# a rank that dies makes the job fail, not hang
signal_one_rank killed 2 KILL
[ $rc -ne 0 ] || { echo "FAIL: a job with a killed rank exited 0"; exit 1; }
[ $rc -ne 124 ] || { echo "FAIL: a job with a killed rank hung"; exit 1; }
pgrep -f "hdnet train data .*-o killed" >/dev/null && { echo "FAIL: a rank outlived the job"; exit 1; }
echo "a killed rank: the job failed (exit $rc): $(grep -m1 -i 'signal\|killed\|exited' killed.log || true)"
echo "mpi train: all checks passed"
