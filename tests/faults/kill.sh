#!/bin/sh
# kill.sh: kill -9 at random moments during `hdnet train`, `decompose` and `synth` (KILLS rounds in
# all, 20 by default, spread over the three), then checks what issue 15 promises
# (docs/reliability.md): right after a kill no image's file set is partial (decompose's seven
# files per texture or face, a photo's maps and recon; synth's eight), and after the next run of the same command (train --resume, decompose
# and synth again into the same folder) no temporary is left anywhere and every set is whole.
# Not part of `make test` (it takes minutes): `make test-kill`, which CI runs under a timeout.
set -u
H=${HDNET:?HDNET is not set}
KILLS=${KILLS:-20}
TEST=kill
. "$(dirname "$0")/../cli_common.shlib"
work=$(mktemp -d "${TMPDIR:-/tmp}/hdnet-kill.XXXXXX")
trap 'rm -rf "$work"' EXIT
cd "$work" || exit 1

# random_ms LO HI: a random number of milliseconds in [LO, HI)
random_ms() { echo $(( $1 + $(od -An -N2 -tu2 /dev/urandom | tr -d ' ') % ($2 - $1) )); }
# sleep_ms N
sleep_ms() { sleep "$(awk -v m="$1" 'BEGIN { printf "%.3f", m / 1000 }')"; }
temporaries() { find "$1" -name '*.tmp.*' | head -5; }
# whole_sets DIR SUFFIX...: every NAME with the first file has all of them (a photo's maps in its
# frame, NAME.photo.*, are a set of their own)
whole_sets() {
    dir=$1
    shift
    for first in $(find "$dir" -name "*$1" ! -name "*.photo$1" | sort); do
        stem=${first%"$1"}
        for s in "$@"; do
            [ -f "$stem$s" ] || fail "partial set in $dir: $first without $stem$s"
        done
    done
}
synth_set() { whole_sets "$1" .albedo.png .mask.png .normal.png .normal_gt.png .shading.png .shading.pfm .light.txt; }
decompose_set() {
    whole_sets "$1" .albedo.png .shading.png .shading.pfm .normal.png .light.txt .recon.png .sheet.png
    whole_sets "$1" .photo.albedo.png .photo.shading.png .photo.shading.pfm .photo.normal.png .photo.mask.png .recon.png
}

expect 0 $H synth data --subjects 3 --per-subject 3 --size 32 --seed 5 --threads 1
expect 0 $H init --width 4 --size 32 --seed 2 -o model.safetensors
T="--size 32 --width 4 --batch 1 --threads 1 -q"

round=0
train_kills=0 decompose_kills=0 synth_kills=0
while [ $round -lt "$KILLS" ]; do
    case $((round % 3)) in
    0)
        what=train
        if [ -f run/checkpoint.safetensors ]; then
            $H train data -o run --threads 1 -q --iters 100000 --every 2 --resume >/dev/null 2>&1 &
        else
            $H train data -o run $T --iters 100000 --every 2 >/dev/null 2>&1 &
        fi
        wait_lo=300 wait_hi=2500 ;;
    1)
        what=decompose
        $H decompose data -m model.safetensors -o dec --batch 2 >/dev/null 2>&1 &
        wait_lo=100 wait_hi=1500 ;;
    2)
        what=synth
        $H synth syn --subjects 40 --per-subject 4 --size 32 --seed 9 --threads 1 >/dev/null 2>&1 &
        wait_lo=100 wait_hi=2000 ;;
    esac
    pid=$!
    sleep_ms "$(random_ms $wait_lo $wait_hi)"
    kill -9 $pid 2>/dev/null && eval "${what}_kills=\$((${what}_kills + 1))"
    wait $pid 2>/dev/null
    # right after the kill: no partial set (the temporaries may be there)
    [ -d dec ] && decompose_set dec
    [ -d syn ] && synth_set syn
    round=$((round + 1))
done

# the next runs: they finish, and leave no temporary and whole sets behind
if [ -f run/checkpoint.safetensors ]; then
    expect 0 $H train data -o run --threads 1 -q --iters 2 --every 2 --resume
else
    expect 0 $H train data -o run $T --iters 2 --every 2
fi
expect 0 $H decompose data -m model.safetensors -o dec --batch 2
expect 0 $H synth syn --subjects 40 --per-subject 4 --size 32 --seed 9 --threads 1
for d in run dec syn; do
    left=$(temporaries $d)
    [ -z "$left" ] || fail "temporaries left in $d after the next run: $left"
done
decompose_set dec
synth_set syn
echo "kill: $train_kills train, $decompose_kills decompose and $synth_kills synth runs killed with -9; no partial set, no temporary after the next run"
