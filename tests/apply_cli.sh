#!/bin/sh
# apply_cli.sh: the commands that use a model (decompose, relight, transfer, delight,
# estimate-light) on tiny inputs with a tiny freshly initialised model, all in aligned-texture mode
# (--aligned; photos are tests/photo_cli.sh's): outputs and their layout,
# transfer = estimate-light + relight --light (byte for byte), usage errors (exit 2), and missing
# or broken models and images (exit 1, naming the file). Runs in a scratch folder.
set -u
here=$(cd "$(dirname "$0")" && pwd)
HDNET=${HDNET:?HDNET must point at the hdnet tool}
# One thread: at 32 x 32 threads add nothing, and on a busy machine they only wait for each other.
OMP_NUM_THREADS=1
export OMP_NUM_THREADS

TEST=apply_cli
. "$(dirname "$0")/cli_common.shlib"

# err_names TEXT: the last command's error output mentions TEXT.
err_names() { grep -q -- "$1" err.log || { cat err.log >&2; fail "error output does not mention '$1'"; }; }


"$HDNET" help >help.txt || fail "$HDNET help failed"
grep -q '^  init ' help.txt || fail "hdnet has no 'init' command"

expect 0 "$HDNET" init --width 4 --size 32 --seed 1 -o m.safetensors
M="-m m.safetensors --aligned"

# Inputs: a 512 x 512 photo, a 40 x 40 sphere picture, a 4 x 4 gray PFM, a folder of subjects
# with a mask companion and one broken image.
cp "$here/../examples/astronaut.png" face.png
expect 0 "$HDNET" light --preset 0 -o l0.txt --preview small.png --size 40
{
    printf 'Pf\n4 4\n-1.0\n'
    i=0
    while [ $i -lt 16 ]; do printf '\000\000\000\077'; i=$((i + 1)); done # 0.5, little endian
} >gray.pfm
mkdir -p data/subj1 data/subj2
cp small.png data/subj1/a.png
cp small.png data/subj1/a.mask.png
cp small.png data/subj2/b.png
echo "not an image" >data/subj2/broken.png

# decompose: one file, then a folder (subject folders kept, the broken image reported, exit 1).
expect 0 "$HDNET" decompose face.png gray.pfm $M -o out1
for f in face gray; do
    exists out1/$f.albedo.png out1/$f.shading.png out1/$f.shading.pfm out1/$f.normal.png out1/$f.light.txt \
        out1/$f.recon.png out1/$f.sheet.png
done
[ "$(grep -c . out1/face.light.txt)" -eq 9 ] || fail "out1/face.light.txt does not hold 9 numbers"
[ "$(png_size out1/face.albedo.png)" = "32 32" ] || fail "albedo is not at the model size: $(png_size out1/face.albedo.png)"
[ "$(png_size out1/face.sheet.png)" = "184 40" ] || fail "sheet is $(png_size out1/face.sheet.png), expected 5 cells of 32 + borders"
expect 1 "$HDNET" decompose data $M -o out2 --batch 2
err_names broken.png
exists out2/subj1/a.albedo.png out2/subj1/a.normal.png out2/subj2/b.sheet.png out2/subj2/b.light.txt
[ ! -e out2/subj2/broken.albedo.png ] || fail "outputs written for a broken image"
grep -q "decomposed 2 images" out.log || fail "decompose summary: $(cat out.log)"

# relight: every way to give a light; outputs at the input's size.
expect 0 "$HDNET" relight face.png $M --preset 3 -o r_preset.png
[ "$(png_size r_preset.png)" = "512 512" ] || fail "relit image is not at the input's size"
expect 0 "$HDNET" relight small.png $M --dir 30,10 --intensity 1 --ambient 0.3 -o r_dir.png --no-keep-brightness
expect 0 "$HDNET" relight small.png $M --light out1/face.light.txt -o r_light.png --keep-brightness
expect 0 "$HDNET" relight small.png $M --preset all -o r_all --sheet r_sheet.png
for k in 0 1 2 3 4 5 6; do exists r_all/small.preset$k.png; done
[ "$(png_size r_sheet.png)" = "400 48" ] || fail "relight sheet is $(png_size r_sheet.png)"
expect 0 "$HDNET" relight data/subj1/a.png $M --preset 1 -o r_masked.png --mask small.png
err_names "a.mask.png" # the companion wins over --mask, with a note
cmp -s r_light.png r_dir.png && fail "different lights gave the same picture"

# transfer = estimate-light REF + relight --light, byte for byte; delight.
expect 0 "$HDNET" transfer small.png --ref face.png $M -o t.png
expect 0 "$HDNET" estimate-light face.png $M -o L.txt --preview sphere.png --size 48
[ "$(png_size sphere.png)" = "48 48" ] || fail "sphere preview size"
expect 0 "$HDNET" relight small.png $M --light L.txt -o t2.png
cmp t.png t2.png || fail "transfer differs from relight under the estimated light"
# the source light: lnet is decompose's light (L-Net's) exactly; fit (the default) is not; both
# work through transfer = estimate-light + relight --light
expect 0 "$HDNET" estimate-light face.png $M --source-light lnet -o Ll.txt
cmp Ll.txt out1/face.light.txt || fail "estimate-light --source-light lnet is not decompose's light"
cmp -s L.txt Ll.txt && fail "the fitted source light is L-Net's to the last digit"
expect 0 "$HDNET" estimate-light face.png $M --source-light fit -o Lf.txt
cmp L.txt Lf.txt || fail "estimate-light's default is not --source-light fit"
expect 0 "$HDNET" transfer small.png --ref face.png $M --source-light lnet -o tl.png
expect 0 "$HDNET" relight small.png $M --light Ll.txt --source-light lnet -o tl2.png
cmp tl.png tl2.png || fail "transfer --source-light lnet differs from relight under L-Net's light"
expect 0 "$HDNET" delight small.png $M --source-light lnet -o dl.png
expect_saying 2 "fit or lnet" "$HDNET" relight small.png $M --preset 1 --source-light bogus -o x.png
expect_saying 2 "fit or lnet" "$HDNET" estimate-light small.png $M --source-light LNET -o x.txt
expect 0 "$HDNET" delight small.png $M -o d.png
expect 0 "$HDNET" delight gray.pfm $M -o d_gray.png
[ "$(png_size d_gray.png)" = "4 4" ] || fail "delit gray image size"

# usage errors: exit 2
expect 2 "$HDNET" relight small.png $M -o x.png
expect 2 "$HDNET" relight small.png $M --preset 7 -o x.png
expect 2 "$HDNET" relight small.png $M --preset 1 --dir 10,10 -o x.png
expect 2 "$HDNET" relight small.png $M --preset 1 --intensity 2 -o x.png
expect 2 "$HDNET" relight small.png $M --preset 1 -o x.png --keep-brightness --no-keep-brightness
expect 2 "$HDNET" relight small.png $M --preset 1
expect 2 "$HDNET" decompose small.png $M
expect 2 "$HDNET" decompose -o out3 $M
expect 2 "$HDNET" decompose small.png $M -o out3 --batch 0
# --white-balance: off is the default byte for byte; eyes runs; a bad value and a wrong mode are
# usage errors (its effect is tests/test_white_balance.c's)
expect 0 "$HDNET" decompose face.png $M -o wb_off --white-balance off
cmp wb_off/face.albedo.png out1/face.albedo.png || fail "--white-balance off differs from the default"
expect 0 "$HDNET" decompose face.png $M -o wb_eyes --white-balance eyes
exists wb_eyes/face.albedo.png wb_eyes/face.recon.png
expect_saying 2 "wants off or eyes" "$HDNET" decompose face.png $M -o wb_bad --white-balance grey
[ ! -e wb_bad ] || fail "a usage error made the output folder"
expect_saying 2 "ground-truth evaluation" "$HDNET" eval data --photos --white-balance eyes
expect_saying 2 "wants off or eyes" "$HDNET" eval data --white-balance 1
expect 2 "$HDNET" transfer small.png $M -o x.png
expect 2 "$HDNET" delight $M -o x.png
expect 2 "$HDNET" estimate-light small.png small.png $M -o x.txt
expect 2 "$HDNET" estimate-light small.png $M -o x.txt --bogus
[ ! -e x.png ] || fail "a usage error wrote an output"

# missing and broken files: exit 1, naming the file
expect 1 "$HDNET" relight small.png -m nothere.safetensors --preset 1 -o x.png
err_names nothere.safetensors
head -c 100 m.safetensors >broken.safetensors
expect 1 "$HDNET" delight small.png -m broken.safetensors -o x.png
err_names broken.safetensors
echo "garbage" >bad.png
expect 1 "$HDNET" delight bad.png $M -o x.png
err_names bad.png
expect 1 "$HDNET" estimate-light nothere.png $M -o x.txt
err_names nothere.png
expect 1 "$HDNET" transfer small.png --ref nothere.png $M -o x.png
err_names nothere.png
expect 1 "$HDNET" relight small.png $M --light nothere.txt -o x.png
err_names nothere.txt
expect 1 "$HDNET" relight small.png $M --preset 1 -o x.png --mask nothere.mask.png
err_names nothere.mask.png
expect 1 "$HDNET" decompose nothere.png $M -o out4
err_names nothere.png
expect 1 "$HDNET" relight small.png $M --preset 1 -o no/such/dir/x.png
err_names no/such/dir/x.png

# without -m: the shipped model, or a clear error naming it while it is not there
if [ -f "$here/../models/hdnet-synth.safetensors" ]; then
    expect 0 "$HDNET" delight small.png --aligned -o d_default.png
    exists d_default.png
else
    expect 1 "$HDNET" delight small.png --aligned -o x.png
    err_names "default model"
fi

# the broken-file corpus (tests/data/broken): every image refused by decompose (one run, each
# named, nothing written), every checkpoint by -m, every light file by --light
broken=${HDNET_TESTDATA:-$here/data}/broken
if [ -d "$broken" ]; then
    expect 1 "$HDNET" decompose "$broken"/*.png "$broken"/*.jpg "$broken"/*.pfm $M -o out5
    for f in "$broken"/*.png "$broken"/*.jpg "$broken"/*.pfm; do err_names "$(basename "$f")"; done
    grep -q "decomposed 0 images" out.log || fail "decompose wrote outputs for broken images"
    for f in "$broken"/*.safetensors; do
        expect 1 "$HDNET" estimate-light small.png --aligned -m "$f" -o x.txt
        err_names "$(basename "$f")"
    done
    for f in "$broken"/*.light.txt; do
        expect 1 "$HDNET" relight small.png $M --light "$f" -o x.png
        err_names "$(basename "$f")"
    done
fi
[ ! -e x.png ] && [ ! -e x.txt ] || fail "a failed command left an output"
echo "apply_cli: all checks passed"
