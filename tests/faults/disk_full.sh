#!/bin/sh
# disk_full.sh: a full disk (a small tmpfs) under `hdnet decompose`, `relight` (a folder), `synth` and `train`: each stops
# at the first failed write with the errno's text ("No space left on device"), exit 1; decompose
# does not go on running the network on the remaining images; no temporary and no partial set is
# left. Needs to mount a tmpfs (root, as in CI): elsewhere it says why and skips. Part of
# `make test-kill`.
set -u
H=${HDNET:?HDNET is not set}
TEST=disk_full
. "$(dirname "$0")/../cli_common.shlib"
work=$(mktemp -d "${TMPDIR:-/tmp}/hdnet-disk.XXXXXX")
mnt=$work/full
mkdir -p "$mnt"
cleanup() { umount "$mnt" 2>/dev/null; rm -rf "$work"; }
trap cleanup EXIT
if ! mount -t tmpfs -o size=160k tmpfs "$mnt" 2>/dev/null; then
    echo "disk_full: skipped: cannot mount a tmpfs here (needs root or CAP_SYS_ADMIN; CI runs it as root)"
    exit 0
fi
cd "$work" || exit 1
temporaries() { find "$1" -name '*.tmp.*' | head -5; }

expect 0 $H synth data --subjects 3 --per-subject 4 --size 64 --seed 5 --threads 1
expect 0 $H init --width 4 --size 64 --seed 2 -o model.safetensors

# decompose: 12 images of about 60 KB of outputs each into 160 KB
expect 1 $H decompose data -m model.safetensors -o "$mnt/dec" --batch 1
grep -q "No space left on device" err.log || fail "decompose on a full disk: $(cat err.log)"
grep -q "stopped at the first write failure" err.log || fail "decompose did not stop: $(cat err.log)"
[ "$(grep -c 'No space left' err.log)" = 1 ] || fail "decompose repeated the error: $(cat err.log)"
[ -z "$(temporaries "$mnt")" ] || fail "decompose left temporaries: $(temporaries "$mnt")"
for a in $(find "$mnt/dec" -name '*.albedo.png'); do
    stem=${a%.albedo.png}
    for s in .shading.png .shading.pfm .normal.png .light.txt .recon.png .sheet.png; do
        [ -f "$stem$s" ] || fail "partial set on the full disk: $a without $stem$s"
    done
done
rm -rf "$mnt/dec"

# relight on a folder (the batch layer every many-photo command runs on): stops at the first ENOSPC
expect 1 $H relight data --aligned -m model.safetensors --preset all -o "$mnt/rel"
grep -q "No space left on device" err.log || fail "relight on a full disk: $(cat err.log)"
grep -q "stopped at the first write failure" err.log || fail "relight did not stop: $(cat err.log)"
[ "$(grep -c 'No space left' err.log)" = 1 ] || fail "relight repeated the error: $(cat err.log)"
[ -z "$(temporaries "$mnt")" ] || fail "relight left temporaries: $(temporaries "$mnt")"
for a in $(find "$mnt/rel" -name '*.preset0.png'); do
    [ -f "${a%.preset0.png}.preset6.png" ] || fail "partial set on the full disk: $a without preset6"
done
rm -rf "$mnt/rel"

# synth: stops with the errno, no temporaries
expect 1 $H synth "$mnt/syn" --subjects 20 --per-subject 4 --size 64 --seed 9 --threads 1
grep -q "No space left on device" err.log || fail "synth on a full disk: $(cat err.log)"
[ -z "$(temporaries "$mnt")" ] || fail "synth left temporaries: $(temporaries "$mnt")"
rm -rf "$mnt/syn"

# train: the checkpoint does not fit
expect 1 $H train data -o "$mnt/run" --size 64 --width 4 --batch 1 --threads 1 -q --iters 2 --every 1
grep -q "No space left on device" err.log || fail "train on a full disk: $(cat err.log)"
[ -z "$(temporaries "$mnt")" ] || fail "train left temporaries: $(temporaries "$mnt")"
echo "disk_full: decompose, relight, synth and train stop at the first ENOSPC with its text, nothing half-written"
