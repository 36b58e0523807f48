#!/bin/sh
# train_cli.sh: `hdnet init` and `hdnet train` on a tiny synthetic set (made with `hdnet synth`):
# the run folder's outputs, --init, exact resume through the CLI, stage 2, the time limit,
# SIGINT, the gradient dump, and the exit codes of bad uses.
set -u
H="$HDNET"
TEST=train_cli
. "$(dirname "$0")/cli_common.shlib"
# the loss columns of a loss.csv (the last column, seconds, differs between runs)
losses() { sed 's/,[^,]*$//' "$1"; }

$H help | grep -q '^  synth ' || fail "hdnet has no 'synth' command"
expect 0 $H synth data --subjects 2 --per-subject 3 --size 32 --seed 4 --threads 1
T="--size 32 --width 4 --batch 1 --threads 1 --seed 3 -q"

# init: a model file of the right size; bad uses are usage errors
expect 0 $H init --width 4 --size 32 --seed 3 -o init.safetensors
[ -s init.safetensors ] || fail "init wrote nothing"
expect 2 $H init --width 4 --size 40 --seed 3 -o bad.safetensors
expect 2 $H init --width 4 -o bad.safetensors
expect 2 $H init --seed 1

# a run: every output is there, one CSV row per iteration
expect 0 $H train data -o run $T --iters 4 --every 2 --dump-grads dump.safetensors
for f in model.safetensors checkpoint.safetensors loss.csv loss.png samples/iter_0000002.png samples/iter_0000004.png; do
    [ -s "run/$f" ] || fail "run/$f missing"
done
[ "$(wc -l < run/loss.csv)" = 5 ] || fail "loss.csv should have a header and 4 rows"
[ -s dump.safetensors ] || fail "no gradient dump"
$H info dump.safetensors --tensors 1000 > dump_info.txt 2>&1 || fail "hdnet info cannot read the gradient dump"
grep -q "grad.conv_in.weight" dump_info.txt || fail "hdnet info does not list the dump's grad.conv_in.weight"

# --init from `hdnet init` with the same seed starts exactly where --seed starts
expect 0 $H train data -o run_init $T --iters 2 --every 2 --init init.safetensors
[ "$(losses run_init/loss.csv)" = "$(losses run/loss.csv | head -3)" ] || fail "--init differs from a fresh start with the same seed"

# resume: 4 + 2 iterations equal 6 straight
expect 0 $H train data -o run $T --iters 6 --every 2 --resume
expect 0 $H train data -o straight $T --iters 6 --every 2
[ "$(losses run/loss.csv)" = "$(losses straight/loss.csv)" ] || fail "resumed losses differ from an uninterrupted run"

# micro-batches: the same run in two forward passes per iteration, resumed with the same split
expect 0 $H train data -o micro $T --batch 2 --micro-batch 1 --iters 2 --every 2
expect 0 $H train data -o micro --threads 1 -q --iters 3 --every 2 --resume
[ "$(wc -l < micro/loss.csv)" = 4 ] || fail "micro-batch run: loss.csv should have 3 rows"
expect 2 $H train data -o y $T --batch 2 --micro-batch -1

# the trained model decomposes (when the command is there)
if $H help | grep -q '^  decompose '; then
    expect 0 $H decompose data/subject_0000/0000.png -m run/model.safetensors -o dec
fi

# stage 2 from the stage 1 model: phase 2a (L-Net) then 2b
expect 0 $H train data -o run2 $T --stage 2 --init run/model.safetensors --iters 3 --lnet-iters 1 --every 3
[ -s run2/checkpoint.safetensors ] || fail "stage 2 wrote no checkpoint"
# --lnet-lr: phase 2a's L-Net steps at their own rate: the first iteration's losses (before any
# step) are the same, the second's (after one 2a step) differ
expect 0 $H train data -o run2lr $T --stage 2 --init run/model.safetensors --iters 3 --lnet-iters 1 --every 3 --lnet-lr 0.05
[ "$(sed -n 2p run2/loss.csv | cut -d, -f1-14)" = "$(sed -n 2p run2lr/loss.csv | cut -d, -f1-14)" ] ||
    fail "--lnet-lr changed the first iteration's losses"
[ "$(sed -n 3p run2/loss.csv | cut -d, -f1-14)" != "$(sed -n 3p run2lr/loss.csv | cut -d, -f1-14)" ] ||
    fail "--lnet-lr did not change phase 2a's step"
expect_saying 2 "goes with --stage 2" $H train data -o y --lnet-lr 0.01
expect_saying 2 "lnet-lr must be in" $H train data -o y --stage 2 --init run/model.safetensors --lnet-lr -1
# a stage 1 checkpoint does not resume as stage 2
expect 1 $H train data -o run $T --stage 2 --iters 8 --resume
grep -q "stage" err.log || fail "stage mismatch not explained: $(cat err.log)"

# the time limit stops after a checkpoint, exit 0
expect 0 $H train data -o timed $T --iters 100000 --every 100000 --time-limit 0.0001
grep -q "time limit" out.log || fail "no time-limit message"
[ -s timed/checkpoint.safetensors ] || fail "no checkpoint at the time limit"

# SIGINT: checkpoint, exit 1, and the run resumes
rm -rf sig # a loss.csv left by an earlier run would end the wait below before the handler is set
$H train data -o sig $T --iters 100000 --every 100000 >sig.out 2>sig.err &
pid=$!
i=0
while [ "$(cat sig/loss.csv 2>/dev/null | wc -l)" -lt 3 ] && [ $i -lt 600 ]; do
    sleep 0.1
    i=$((i + 1))
done
kill -INT $pid
wait $pid
[ $? = 1 ] || fail "SIGINT should end with exit 1"
[ -s sig/checkpoint.safetensors ] || fail "no checkpoint after SIGINT"
done_iters=$(($(wc -l < sig/loss.csv) - 1))
expect 0 $H train data -o sig $T --iters $((done_iters + 1)) --every 100000 --resume

# the options for sets with ground truth: an eighth loss column that is nonzero only when asked for,
# and a different light loss when l_hat is the true light
expect 0 $H train data -o gtrun $T --iters 2 --every 2 --w-albedo-gt 1 --prior-normals gt --light-target gt
head -1 gtrun/loss.csv | grep -q ",albedo_gt," || fail "no albedo_gt column: $(head -1 gtrun/loss.csv)"
agt() { sed -n 2p "$1" | cut -d, -f10; }
[ "$(agt run/loss.csv)" = 0 ] || fail "albedo_gt should be 0 by default, is $(agt run/loss.csv)"
awk "BEGIN { exit !($(agt gtrun/loss.csv) > 0.01) }" || fail "albedo_gt should be on: $(agt gtrun/loss.csv)"
[ "$(sed -n 2p gtrun/loss.csv | cut -d, -f7)" != "$(sed -n 2p run/loss.csv | cut -d, -f7)" ] ||
    fail "--light-target gt did not change the light loss"
expect 2 $H train data -o y --prior-normals nope
# l_hat from the image's luminance: the light term changes, the image terms of step 1 do not
expect 0 $H train data -o imgrun $T --iters 2 --every 2 --light-target image
[ "$(sed -n 2p imgrun/loss.csv | cut -d, -f3-6)" = "$(sed -n 2p run/loss.csv | cut -d, -f3-6)" ] ||
    fail "--light-target image changed a term that does not read l_hat"
[ "$(sed -n 2p imgrun/loss.csv | cut -d, -f7)" != "$(sed -n 2p run/loss.csv | cut -d, -f7)" ] ||
    fail "--light-target image did not change the light loss"
# the shading prior's options: bad values are usage errors; the skin-only fit changes the prior's
# term (column 12) of step 1 and none of the image terms
expect 2 $H train data -o y --shading-prior-normals nope
expect 2 $H train data -o y --light-fit nope
head -1 run/loss.csv | cut -d, -f12 | grep -qx shading_prior || fail "column 12 is not shading_prior: $(head -1 run/loss.csv)"
expect 0 $H train data -o skinrun $T --iters 2 --every 2 --light-fit skin
[ "$(sed -n 2p skinrun/loss.csv | cut -d, -f3-6)" = "$(sed -n 2p run/loss.csv | cut -d, -f3-6)" ] ||
    fail "--light-fit skin changed a term that does not read the prior"
[ "$(sed -n 2p skinrun/loss.csv | cut -d, -f12)" != "$(sed -n 2p run/loss.csv | cut -d, -f12)" ] ||
    fail "--light-fit skin did not change the shading prior"
expect 0 $H train data -o prednrun $T --iters 2 --every 2 --shading-prior-normals predicted
[ "$(sed -n 2p prednrun/loss.csv | cut -d, -f12)" != "$(sed -n 2p run/loss.csv | cut -d, -f12)" ] ||
    fail "--shading-prior-normals predicted did not change the shading prior"
# the scale anchor: a ninth column, on by default, 0 when its weight is 0 (only the total changes)
head -1 run/loss.csv | grep -q ",shading_mean," || fail "no shading_mean column: $(head -1 run/loss.csv)"
expect 0 $H train data -o noanchor $T --iters 2 --every 2 --w-shading-mean 0
awk -F, 'NR == 2 { exit !($11 > 0) }' run/loss.csv || fail "shading_mean should be on by default"
# the shading prior: a tenth column, on by default: weight 0 changes the first step's total only
head -1 run/loss.csv | grep -q ",shading_prior,light_pair,fit_pair,disc," || fail "no shading_prior column: $(head -1 run/loss.csv)"
awk -F, 'NR == 2 { exit !($12 > 0) }' run/loss.csv || fail "the shading prior's value should be positive"
expect 0 $H train data -o noprior $T --iters 2 --every 2 --w-shading-prior 0
[ "$(sed -n 2p noprior/loss.csv | cut -d, -f3-12)" = "$(sed -n 2p run/loss.csv | cut -d, -f3-12)" ] ||
    fail "the shading prior's weight changed the first step's terms"
[ "$(sed -n 2p noprior/loss.csv | cut -d, -f2)" != "$(sed -n 2p run/loss.csv | cut -d, -f2)" ] ||
    fail "the shading prior should be on by default (its weight 0 left the total unchanged)"
expect 2 $H train data -o x $T --iters 2 --shading-prior-iters -1
[ "$(sed -n 2p noanchor/loss.csv | cut -d, -f3-11)" = "$(sed -n 2p run/loss.csv | cut -d, -f3-11)" ] ||
    fail "the anchor's weight changed the first step's terms"
[ "$(sed -n 2p noanchor/loss.csv | cut -d, -f2)" != "$(sed -n 2p run/loss.csv | cut -d, -f2)" ] ||
    fail "the anchor's weight did not change the total"
expect 2 $H train data -o y --shading-mean 0
expect 2 $H train data -o y --shading-mean-over subject
# on the pair: where both images' mean shadings lie on one side of c (c = 50), the pair's term
# and gradient equal the per-image ones, so the whole first two rows agree (test_train checks
# the case between them); the shading prior is off here (its column, still logged, differs: the
# pair also scales its target once per pair)
expect 0 $H train data -o imageanchor $T --iters 2 --every 2 --shading-mean 50 --w-shading-prior 0
expect 0 $H train data -o pairanchor $T --iters 2 --every 2 --shading-mean 50 --shading-mean-over pair --w-shading-prior 0
[ "$(cut -d, -f2-11,13-14 pairanchor/loss.csv)" = "$(cut -d, -f2-11,13-14 imageanchor/loss.csv)" ] ||
    fail "--shading-mean-over pair differs from the image anchor with both means below c"
# with the prior on, the pair's one scale changes the prior's target, so its first value (same S) differs
expect 0 $H train data -o imageprior $T --iters 1 --every 1
expect 0 $H train data -o pairprior $T --iters 1 --every 1 --shading-mean-over pair
[ "$(sed -n 2p imageprior/loss.csv | cut -d, -f12)" != "$(sed -n 2p pairprior/loss.csv | cut -d, -f12)" ] ||
    fail "--shading-mean-over pair did not change the shading prior's target"
[ "$(sed -n 2p imageprior/loss.csv | cut -d, -f3-9)" = "$(sed -n 2p pairprior/loss.csv | cut -d, -f3-9)" ] ||
    fail "--shading-mean-over pair changed the first step's paper terms"

# the camera's colour gain in L_Irec: on a set where every image has a white balance cast, the
# first step's rec (column 3) changes and no other term does; a bad value is a usage error, and a
# malformed record is a warning that names the file
expect 2 $H train data -o y --rec-gain nope
expect 0 $H synth cam --subjects 2 --per-subject 3 --size 32 --seed 4 --camera 1 --camera-effects white-balance --threads 1
expect 0 $H train cam -o camoff $T --iters 1 --every 1
expect 0 $H train cam -o camon $T --iters 1 --every 1 --rec-gain camera
[ "$(sed -n 2p camoff/loss.csv | cut -d, -f3)" != "$(sed -n 2p camon/loss.csv | cut -d, -f3)" ] ||
    fail "--rec-gain camera did not change L_Irec on a white-balanced set"
[ "$(sed -n 2p camoff/loss.csv | cut -d, -f4-13)" = "$(sed -n 2p camon/loss.csv | cut -d, -f4-13)" ] ||
    fail "--rec-gain camera changed a term other than L_Irec"
for f in cam/subject_0000/*.camera.txt; do echo "white_balance 1.2" > "$f"; done
expect_saying 0 "camera.txt:1: white_balance takes 3 numbers" $H train cam -o cambad $T --iters 4 --every 4 --rec-gain camera

# mixed domains: a second set without ground truth (the images of another synth set, alone);
# drawn from it only (--real-share 1) the ground-truth term reads nothing, drawn never it does,
# and --mirror-pairs makes pairs of a single image per subject
expect 0 $H synth other --subjects 2 --per-subject 1 --size 32 --seed 9 --threads 1
mkdir -p real/a real/b
for s in 0 1; do
    for k in png mask.png normal.png; do cp other/subject_000$s/0000.$k real/$(echo ab | cut -c$((s + 1)))/0000.$k; done
done
expect 1 $H train data -o mix $T --iters 2 --real real
grep -q "no real pairs" err.log || fail "a real set without pairs not reported: $(cat err.log)"
expect 0 $H train data -o mix $T --iters 3 --every 3 --w-albedo-gt 1 --real real --real-share 1 --mirror-pairs
awk -F, 'NR > 1 && $10 != 0 { exit 1 }' mix/loss.csv || fail "real pairs read a ground truth: $(cat mix/loss.csv)"
expect 0 $H train data -o mix0 $T --iters 2 --every 2 --w-albedo-gt 1 --real real --real-share 0 --mirror-pairs
awk -F, 'NR == 2 { exit !($10 > 0.01) }' mix0/loss.csv || fail "synthetic pairs lost their ground truth"
expect 0 $H train data -o mix $T --iters 5 --every 3 --w-albedo-gt 1 --real real --real-share 1 --mirror-pairs --resume
expect 0 $H train data -o mixs $T --iters 5 --every 3 --w-albedo-gt 1 --real real --real-share 1 --mirror-pairs
[ "$(losses mix/loss.csv)" = "$(losses mixs/loss.csv)" ] || fail "a resumed mixed run differs from a straight one"
# L_lpair: a mirror pair's lights are related (column 13 positive on every row: these real
# subjects have one image each, so every real pair is a mirror pair), a synthetic pair's are not
awk -F, 'NR > 1 && !($13 > 0) { exit 1 }' mix/loss.csv || fail "mirror pairs without L_lpair: $(cat mix/loss.csv)"
awk -F, 'NR > 1 && $13 != 0 { exit 1 }' mix0/loss.csv || fail "synthetic pairs with L_lpair: $(cat mix0/loss.csv)"
# two photos of one person (from a trained model: an initial L-Net gives every image one light):
# related only with --real-same-light; the weight moves the total only
expect 0 $H synth other2 --subjects 1 --per-subject 2 --size 32 --seed 10 --threads 1
mkdir -p real2/a
for i in 0000 0001; do for k in png mask.png normal.png; do cp other2/subject_0000/$i.$k real2/a/$i.$k; done; done
expect 0 $H train data -o same0 $T --iters 2 --every 2 --init run/model.safetensors --real real2 --real-share 1
awk -F, 'NR > 1 && $13 != 0 { exit 1 }' same0/loss.csv || fail "L_lpair without --real-same-light: $(cat same0/loss.csv)"
expect 0 $H train data -o same1 $T --iters 2 --every 2 --init run/model.safetensors --real real2 --real-share 1 --real-same-light
awk -F, 'NR > 1 && !($13 > 0) { exit 1 }' same1/loss.csv || fail "no L_lpair with --real-same-light: $(cat same1/loss.csv)"
expect 0 $H train data -o same2 $T --iters 1 --every 1 --init run/model.safetensors --real real2 --real-share 1 --real-same-light --w-light-pair 3
[ "$(sed -n 2p same2/loss.csv | cut -d, -f3-13)" = "$(sed -n 2p same1/loss.csv | cut -d, -f3-13)" ] ||
    fail "the weight of L_lpair changed the first step's terms"
[ "$(sed -n 2p same2/loss.csv | cut -d, -f2)" != "$(sed -n 2p same1/loss.csv | cut -d, -f2)" ] ||
    fail "the weight of L_lpair did not change the total"
# L_fpair: a fourteenth column, 0 until its weight is set, then on the same-light pairs, where
# its weight changes the total only
awk -F, 'NR > 1 && $14 != 0 { exit 1 }' same1/loss.csv || fail "L_fpair without --w-fit-pair: $(cat same1/loss.csv)"
expect 0 $H train data -o same3 $T --iters 1 --every 1 --init run/model.safetensors --real real2 --real-share 1 --real-same-light --w-fit-pair 2
awk -F, 'NR > 1 && !($14 > 0) { exit 1 }' same3/loss.csv || fail "no L_fpair with --w-fit-pair: $(cat same3/loss.csv)"
[ "$(sed -n 2p same3/loss.csv | cut -d, -f3-13)" = "$(sed -n 2p same1/loss.csv | cut -d, -f3-13)" ] ||
    fail "the weight of L_fpair changed the first step's other terms"
[ "$(sed -n 2p same3/loss.csv | cut -d, -f2)" != "$(sed -n 2p same1/loss.csv | cut -d, -f2)" ] ||
    fail "the weight of L_fpair did not change the total"
expect 0 $H train data -o same4 $T --iters 1 --every 1 --init run/model.safetensors --real real2 --real-share 1 --w-fit-pair 2
awk -F, 'NR > 1 && $14 != 0 { exit 1 }' same4/loss.csv || fail "L_fpair on unrelated pairs: $(cat same4/loss.csv)"
expect 2 $H train data -o y --real-same-light
# a run from before light_pair and fit_pair (its loss.csv without those columns) resumes into
# today's columns: the old rows keep their values, both read 0 there, every row has 16 fields
expect 0 $H train data -o oldcsv $T --iters 2 --every 2
awk -F, -v OFS=, '{ $13 = ""; $14 = ""; sub(",,,", ","); print }' oldcsv/loss.csv > oldcsv/old.csv
head -1 oldcsv/old.csv | grep -q ",shading_prior,disc,seconds$" || fail "the old-format loss.csv was not made: $(head -1 oldcsv/old.csv)"
cp oldcsv/loss.csv oldcsv/new.csv
mv oldcsv/old.csv oldcsv/loss.csv
expect 0 $H train data -o oldcsv $T --iters 3 --every 3 --resume
awk -F, 'NF != 16 { exit 1 }' oldcsv/loss.csv || fail "resumed rows with the wrong column count: $(cat oldcsv/loss.csv)"
[ "$(head -1 oldcsv/loss.csv)" = "$(head -1 oldcsv/new.csv)" ] || fail "the resumed header is not today's"
for r in 2 3; do
    [ "$(sed -n ${r}p oldcsv/loss.csv | cut -d, -f1-12,15-16)" = "$(sed -n ${r}p oldcsv/new.csv | cut -d, -f1-12,15-16)" ] ||
        fail "row $r of an old-format loss.csv changed on resume: $(sed -n ${r}p oldcsv/loss.csv)"
    [ "$(sed -n ${r}p oldcsv/loss.csv | cut -d, -f13-14)" = 0,0 ] || fail "an old row's light_pair or fit_pair is not 0"
done
expect_saying 2 "w-shading-prior must not be negative" $H train data -o y --w-shading-prior -1
expect 2 $H train data -o y --mirror-pairs
expect 2 $H train data -o y --real real --real-share 2
expect 2 $H train data -o y --light-target nope

# bad uses
expect 1 $H train no-such-folder -o x $T --iters 1
grep -q "no-such-folder" err.log || fail "missing folder not named: $(cat err.log)"
expect 1 $H train data -o empty-run $T --iters 2 --resume
grep -q "checkpoint.safetensors" err.log || fail "missing checkpoint not named: $(cat err.log)"
head -c 100 run/model.safetensors > torn.safetensors
expect 1 $H train data -o y $T --iters 1 --init torn.safetensors
grep -q "torn.safetensors" err.log || fail "torn model not named: $(cat err.log)"
expect 1 $H train data -o y $T --width 8 --iters 1 --init run/model.safetensors
grep -q "width" err.log || fail "width mismatch not explained: $(cat err.log)"
expect 2 $H train data -o y --size 40
expect 2 $H train data -o y --weights nope
expect 2 $H train data
expect 2 $H train data -o y --stage 3
echo "train_cli: ok"
