#!/bin/sh
# synth_cli.sh: `hdnet synth` and `hdnet eval` from the command line: a tiny set has every SPEC
# section 5 file and a preview; the same seed gives the same files; --coarse-error changes only the
# coarse normals, --png fast only the PNGs' compression; the set's ground truth, laid out as
# `hdnet decompose` writes predictions, scores zero errors and 100 % lighting classification with
# the baselines under it; a model is scored too; bad options give the documented exit codes.
set -u
TEST=synth_cli
. "$(dirname "$0")/cli_common.shlib"

expect_saying 0 "synth 6/6" "$HDNET" synth set --subjects 3 --per-subject 2 --size 32 --seed 5 --pose-jitter 5
for f in 0000.png 0000.mask.png 0000.normal.png 0000.albedo.png 0000.normal_gt.png 0000.shading.png \
         0000.shading.pfm 0000.light.txt 0001.png; do
    [ -s "set/subject_0002/$f" ] || fail "set/subject_0002/$f is missing"
done
[ -s set/preview.sheet.png ] || fail "no preview sheet"
[ "$(wc -l <set/subject_0000/0001.light.txt)" -eq 9 ] || fail "light file is not 9 lines"
expect_saying 0 "synth 6/6" "$HDNET" synth again --subjects 3 --per-subject 2 --size 32 --seed 5 --pose-jitter 5 --threads 1
cmp -s set/subject_0001/0001.png again/subject_0001/0001.png || fail "same seed, different image"
cmp -s set/subject_0001/0001.light.txt again/subject_0001/0001.light.txt || fail "same seed, different light"
cmp -s set/subject_0001/0001.normal.png again/subject_0001/0001.normal.png || fail "same seed, different coarse normals"
# --coarse-error 0 (exact pose, undeformed mesh) changes the coarse normals and nothing else
expect_saying 0 "synth 6/6" "$HDNET" synth exact --subjects 3 --per-subject 2 --size 32 --seed 5 --pose-jitter 5 --coarse-error 0
cmp -s set/subject_0001/0001.normal.png exact/subject_0001/0001.normal.png && fail "--coarse-error 0 gives the default's coarse normals"
for f in 0001.png 0001.mask.png 0001.albedo.png 0001.normal_gt.png 0001.shading.pfm 0001.light.txt; do
    cmp -s "set/subject_0001/$f" "exact/subject_0001/$f" || fail "--coarse-error changed $f"
done
# --png fast: the same set with compressed PNGs (smaller files than the default --png store; test_synth
# checks that both decode to the same samples), the PFM and the light byte for byte the same
expect_saying 0 "synth 6/6" "$HDNET" synth compact --subjects 3 --per-subject 2 --size 32 --seed 5 --pose-jitter 5 --png fast
for f in 0001.shading.pfm 0001.light.txt; do
    cmp -s "set/subject_0001/$f" "compact/subject_0001/$f" || fail "--png fast changed $f"
done
for f in 0001.png 0001.normal.png 0001.normal_gt.png 0001.shading.png; do
    [ "$(wc -c <"set/subject_0001/$f")" -gt "$(wc -c <"compact/subject_0001/$f")" ] || fail "--png fast: $f is not smaller"
done

# ground truth as a prediction, in hdnet decompose's layout
for d in set/subject_*; do
    s=$(basename "$d")
    mkdir -p "pred/$s"
    for img in "$d"/[0-9][0-9][0-9][0-9].png; do
        n=$(basename "$img" .png)
        cp "$d/$n.albedo.png" "$d/$n.shading.pfm" "$d/$n.light.txt" "pred/$s/"
        cp "$d/$n.normal_gt.png" "pred/$s/$n.normal.png"
        cp "$img" "pred/$s/$n.recon.png"
    done
done
expect_saying 0 "coarse normals" "$HDNET" eval set --pred pred -o eval.json
grep -q "^wrote eval.json" out.log || fail "eval -o did not say what it wrote"
grep -q "^predictions  *0.00 +-  0.00   100.0   100.0   100.0 |  0.0000  0.0000  0.0000 |  0.0000  0.0000 |  0.0000 |  100.00" out.log ||
    { cat out.log >&2; fail "ground truth as a prediction is not a perfect score"; }
grep -q '"images":	6' eval.json || fail "eval.json lacks the image count"
grep -q '"light_accuracy_pct":	100' eval.json || fail "eval.json lacks the perfect light score"
# --json prints the same document on stdout (like every command's --json), not the table
expect 0 "$HDNET" eval set --pred pred --json
cmp -s out.log eval.json || { diff out.log eval.json >&2; fail "eval --json on stdout differs from eval -o eval.json"; }
expect_saying 2 "write it to a file with -o eval.json" "$HDNET" eval set --pred pred --json eval.json
grep -q '"source_light":	"lnet"' eval.json || fail "eval.json does not say it scored the prediction's own light"
# --source-light fit scores the least-squares light of the prediction's shading on its normals (the
# relighting rule's face light) instead of its NAME.light.txt: with every light file zeroed, the
# default's light column falls and the fit's (the true shading on the true normals) stays perfect,
# and nothing else in the table changes
mkdir zpred
for d in pred/*; do
    mkdir "zpred/$(basename "$d")"
    cp "$d"/* "zpred/$(basename "$d")/"
done
for f in zpred/*/*.light.txt; do printf '0\n0\n0\n0\n0\n0\n0\n0\n0\n' >"$f"; done
expect 0 "$HDNET" eval set --pred zpred -o zero.json
grep -q '"light_accuracy_pct":	100' zero.json && fail "zeroed lights still classify 100 %"
expect_saying 0 "the fit of S on N (--source-light fit)" "$HDNET" eval set --pred zpred --source-light fit -o fit.json
grep -q '"source_light":	"fit"' fit.json || fail "fit.json does not say it scored the fitted light"
grep -q "^predictions  *0.00 +-  0.00   100.0   100.0   100.0 |  0.0000  0.0000  0.0000 |  0.0000  0.0000 |  0.0000 |  100.00" out.log ||
    { cat out.log >&2; fail "the true shading's fit on the true normals does not classify 100 %"; }
expect 0 "$HDNET" eval set --pred zpred --source-light lnet -o lnet.json
cmp -s zero.json lnet.json || fail "--source-light lnet is not the ground-truth evaluation's default"
expect_saying 2 "fit or lnet" "$HDNET" eval set --pred pred --source-light other
expect_saying 2 "goes with --photos, --pairs or --multilight" "$HDNET" eval set --pred pred --guard 0.1
# a flat folder (one subject's images directly in DATA): decompose writes OUT/NAME.*, which is
# where eval --pred looks for them (the naming rule, docs/usage.md)
expect 0 "$HDNET" init --width 4 --size 32 --seed 2 -o flat.safetensors
expect 0 "$HDNET" decompose set/subject_0001 -m flat.safetensors -o flatpred
exists flatpred/0000.albedo.png flatpred/0001.albedo.png
expect_saying 0 "coarse normals" "$HDNET" eval set/subject_0001 --pred flatpred --json
grep -q '"images":	2' out.log || { cat out.log >&2; fail "eval --pred of a flat folder's decomposition did not score its 2 images"; }

# a (random, tiny) model scored on the same set: every column of its row filled, the baselines unchanged
expect_saying 0 "wrote m.safetensors" "$HDNET" init --width 8 --size 32 --seed 1 -o m.safetensors
expect_saying 0 "^hdnet model " "$HDNET" eval set -m m.safetensors
grep "^hdnet model" out.log | grep -q -- " - " && { cat out.log >&2; fail "the model's row has empty columns"; }
# --true-shading: a fifth row, N-Net on the set's true shading, with its normals only
expect_saying 0 "^N-Net on true shading " "$HDNET" eval set -m m.safetensors --true-shading -o ts.json
grep "^N-Net on true shading" out.log | grep -q -- " - " || { cat out.log >&2; fail "the true-shading row fills more than normals"; }
grep -q '"name":	"N-Net on true shading"' ts.json || fail "ts.json lacks the true-shading row"
grep -q "N-Net on true shading" eval.json && fail "eval without --true-shading has its row"
expect_saying 2 "--true-shading goes with a model" "$HDNET" eval set --pred pred --true-shading

# usage errors and failures
expect_saying 2 "subjects" "$HDNET" synth x --per-subject 2
expect_saying 2 "size" "$HDNET" synth x --subjects 1 --per-subject 1 --size 8
expect_saying 2 "coarse-error" "$HDNET" synth x --subjects 1 --per-subject 1 --coarse-error 50
expect_saying 2 "neither fast nor store" "$HDNET" synth x --subjects 1 --per-subject 1 --png zip
expect_saying 2 "exclude each other" "$HDNET" eval set -m m.safetensors --pred pred # without either: the shipped model (tests/cli_options.sh)
expect_saying 1 "no_such_dir" "$HDNET" eval no_such_dir --pred pred
expect_saying 1 "" "$HDNET" eval set --pred no_such_pred
exit 0
