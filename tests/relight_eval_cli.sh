#!/bin/sh
# relight_eval_cli.sh: issue 12 end to end with a tiny freshly initialised model (a bad model on
# purpose: the rule must hold up anyway). `hdnet eval --photos` on one real person
# (tests/data/faces-london/001, CC BY 4.0, models/THIRD_PARTY.md): under the ratio rule the face's
# own light gives the input exactly (self 0), a grey light keeps the colours (chroma <= 10) and the
# change has no seam (seam <= 1.5), whatever the model; the paper's rule fails self. `--pairs` on a
# small synthetic set: the exact decomposition is far closer to the truth than the input left
# unchanged. Coloured lights: a 27-number light file, --dir with --colour (warmer than the grey
# light in the face), an environment map.
# `decompose` on a photo writes the full-resolution maps in the photo's frame.
set -u
root=$(cd "$(dirname "$0")/.." && pwd)
HDNET=${HDNET:?HDNET must point at the hdnet tool}
TEST=relight_eval_cli
. "$(dirname "$0")/cli_common.shlib"
LC_ALL=C
export LC_ALL
people="$root/tests/data/faces-london"
photo="$people/001/neutral.jpg"

# json_num FILE GROUP METRIC: a median from the --json output (cJSON prints one key a line).
json_num() {
    awk -v g="\"$2\":" -v m="\"$3\":" '$1 == g { on = 1 } on && $1 == m { gsub(/,/, "", $2); print $2; exit }' "$1"
}

expect 0 "$HDNET" init --width 4 --size 32 --seed 3 -o m.safetensors

expect 0 "$HDNET" eval "$people" --photos -m m.safetensors -o ratio.json
cat out.log
self=$(json_num ratio.json all self)
chroma=$(json_num ratio.json all chroma)
seam=$(json_num ratio.json all seam)
[ "$self" = "0" ] || fail "self is $self under the ratio rule, expected exactly 0"
awk -v c="$chroma" -v s="$seam" 'BEGIN { exit !(c <= 10 && s <= 1.5) }' || fail "chroma $chroma or seam $seam over target"
grep -q '"photo":	"001/neutral"' ratio.json || fail "the JSON does not name the photos"
expect 0 "$HDNET" eval "$people" --photos -m m.safetensors --rule paper -o paper.json
pself=$(json_num paper.json all self)
awk -v s="$pself" 'BEGIN { exit !(s > 0.01) }' || fail "the paper's rule scores self $pself: the measure cannot fail"
grep -q '"source_light":	"fit"' ratio.json || fail "ratio.json does not name the source light fit"
# L-Net's light as the source: still exactly the identity under it
expect 0 "$HDNET" eval "$people" --photos -m m.safetensors --source-light lnet --guard 0.1 -o lnet.json
[ "$(json_num lnet.json all self)" = "0" ] || fail "self is not 0 with --source-light lnet"
grep -q '"source_light":	"lnet"' lnet.json || fail "lnet.json does not name the source light lnet"
grep -q '"guard":	0.1' lnet.json || fail "lnet.json does not give the guard 0.1"
expect_saying 2 "--rule wants" "$HDNET" eval "$people" --photos --rule other
expect_saying 2 "fit or lnet" "$HDNET" eval "$people" --photos --source-light other
expect_saying 2 "--guard wants" "$HDNET" eval "$people" --photos --guard -1
expect_saying 2 "--guard goes with --photos, --pairs or --multilight" "$HDNET" eval "$people" --guard 0.1
expect_saying 2 "exclude" "$HDNET" eval "$people" --photos --pairs

# paired synthetic set
expect 0 "$HDNET" synth syn --subjects 2 --per-subject 2 --size 64 --seed 77
expect 0 "$HDNET" eval syn --pairs -m m.safetensors -o pairs.json
cat out.log
unchanged=$(awk '$1 == "input" { print $3 }' out.log)
exact=$(awk '$1 == "exact" && $2 == "decomposition" { print $3 }' out.log)
awk -v u="$unchanged" -v e="$exact" 'BEGIN { exit !(e < 0.5 * u) }' || fail "exact decomposition MAE $exact is not below half of unchanged $unchanged"
grep -q '"ssim"' pairs.json || fail "no SSIM in pairs.json"
# the guard costs the rule with the true normals and light: a larger one lands farther from j
ratio_at() { awk '$1 == "exact" && $2 == "ratio" { print $6 }' "$1"; }
cp out.log pairs_default.txt
expect 0 "$HDNET" eval syn --pairs -m m.safetensors --guard 0.3
cp out.log pairs_g03.txt
r1=$(ratio_at pairs_default.txt)
r3=$(ratio_at pairs_g03.txt)
awk -v a="$r1" -v b="$r3" 'BEGIN { exit !(a > 0 && b > a) }' || fail "exact ratio MAE $r1 with the default guard, $r3 with 0.3: expected it to grow"
grep -q "guard 0.3" pairs_g03.txt || fail "the pairs table does not give the guard"
# --json: the same document on stdout, instead of the table
expect 0 "$HDNET" eval syn --pairs -m m.safetensors --json
cmp -s out.log pairs.json || { diff out.log pairs.json >&2; fail "eval --pairs --json on stdout differs from -o pairs.json"; }

# coloured lights: a 27-number file; a direction with a colour; an environment map (PFM)
awk 'BEGIN { for (c = 0; c < 3; c++) for (k = 0; k < 9; k++) print (k == 0 ? 2.5 - c : 0) }' >rgb.txt
expect 0 "$HDNET" relight "$photo" -m m.safetensors --light rgb.txt -o rgb.pfm
expect 0 "$HDNET" relight "$photo" -m m.safetensors --dir 30,10 --colour 1,0.8,0.6 -o warm.png
exists warm.png
# the warm light's output is warmer than the grey one's in the face: over the pixels where the two
# differ (outside the face both keep the photo), red minus blue is larger under the warm light
expect 0 "$HDNET" relight "$photo" -m m.safetensors --dir 30,10 --colour 1,0.8,0.6 -o warm.pfm
expect 0 "$HDNET" relight "$photo" -m m.safetensors --dir 30,10 -o grey.pfm
pfm_pixels() { od -An -v -f -w12 -j "$(head -n 3 "$1" | wc -c)" "$1"; } # one pixel (R G B) a line
pfm_pixels warm.pfm >warm.txt
pfm_pixels grey.pfm >grey.txt
warmth=$(paste warm.txt grey.txt | awk '$1 != $4 || $2 != $5 || $3 != $6 { n++; w += $1 - $3; g += $4 - $6 }
    END { if (n) printf "%d %.4f %.4f\n", n, w / n, g / n; else print 0, 0, 0 }')
echo "$warmth" | awk '{ exit !($1 > 1000 && $2 > $3 + 0.05) }' ||
    fail "the warm light is not warmer than the grey one in the face (pixels, mean R - B warm, grey: $warmth)"
{
    printf 'PF\n8 4\n-1.0\n'
    i=0
    while [ $i -lt 96 ]; do printf '\000\000\200\077'; i=$((i + 1)); done # 8 x 4 x RGB of 1.0f
} >env.pfm
expect 0 "$HDNET" relight "$photo" -m m.safetensors --env env.pfm --rotate 30 -o env.png
expect_saying 2 "--rotate goes with --env" "$HDNET" relight "$photo" -m m.safetensors --preset 0 --rotate 3 -o x.png
printf '1 2 3\n' >short.txt
expect_saying 1 "short.txt" "$HDNET" relight "$photo" -m m.safetensors --light short.txt -o x.png
[ ! -e x.png ] || fail "a failed relight left x.png"

# decompose: the full-resolution maps in the photo's frame
expect 0 "$HDNET" decompose "$photo" -m m.safetensors -o dec
for k in albedo shading normal mask; do
    exists dec/neutral.photo.$k.png
    [ "$(png_size dec/neutral.photo.$k.png)" = "675 675" ] || fail "neutral.photo.$k.png is $(png_size dec/neutral.photo.$k.png)"
done
exists dec/neutral.photo.shading.pfm dec/neutral.face0.albedo.png dec/neutral.recon.png
echo "$TEST: ok"
