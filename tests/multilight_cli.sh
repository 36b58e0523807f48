#!/bin/sh
# multilight_cli.sh: `hdnet eval --multilight` end to end (docs/evaluation.md) on a set this test
# writes itself, never on the Yale photos: two London faces (tests/data/faces, CC BY 4.0,
# models/THIRD_PARTY.md), each "photographed" under five known lights by `hdnet relight --dir`
# with a distant light and no ambient, listed in lights.csv in the Yale convention (azimuth > 0
# lights the image's LEFT, so hdnet's --dir azimuth is the negated one). The eval's relight row
# makes the same pictures again, so it scores about 0 where the input unchanged does not, and a
# lights.csv with the azimuths' signs flipped scores far worse: the conventions meet. Also: the
# sheets, --lights, the JSON's counts, the per-subject means, and bad input refused with the file
# named.
set -u
root=$(cd "$(dirname "$0")/.." && pwd)
HDNET=${HDNET:?HDNET must point at the hdnet tool}
TEST=multilight_cli
. "$(dirname "$0")/cli_common.shlib"
LC_ALL=C
export LC_ALL

# json_num FILE KEY FIELD: FIELD ("mean", "n") of the first object KEY in the --json output.
json_num() {
    awk -v k="\"$2\":" -v f="\"$3\":" '$1 == k { on = 1 } on && $1 == f { gsub(/,/, "", $2); print $2; exit }' "$1"
}
json_int() { awk -v k="\"$2\":" '$1 == k { gsub(/,/, "", $2); print $2; exit }' "$1"; }

mkdir -p set
echo "file,subject,azimuth_deg,elevation_deg" > set/lights.csv
echo "file,subject,azimuth_deg,elevation_deg" > flipped.csv
for who in 001 008; do
    mkdir -p "set/p$who"
    cp "$root/tests/data/faces/london-$who.jpg" "set/p$who/p${who}_A+000E+00.jpg"
    echo "p$who/p${who}_A+000E+00.jpg,p$who,0,0" >> set/lights.csv
    echo "p$who/p${who}_A+000E+00.jpg,p$who,0,0" >> flipped.csv
    for light in 25:0 -50:0 0:45 60:-20 -35:40; do
        az=${light%:*}
        el=${light#*:}
        name="p$who/p${who}_A${az}E${el}.png"
        expect 0 "$HDNET" relight "set/p$who/p${who}_A+000E+00.jpg" --dir "$((-az)),$el" --intensity 1 --ambient 0 \
            -o "set/$name"
        echo "$name,p$who,$az,$el" >> set/lights.csv
        echo "$name,p$who,$((-az)),$el" >> flipped.csv
    done
done

lights="A+025E+00,A-050E+00,A+000E+45,A+060E-20,A-035E+40"
expect 0 "$HDNET" eval set --multilight --lights "$lights" --refs 1 --sheets sheets -o ml.json
cat out.log
for row in "input unchanged" "hdnet transfer" "hdnet relight (true direction)" "photometric stereo (bound)"; do
    grep -q "^$row" out.log || fail "the table lacks the row '$row'"
done
grep -q "^A-050E+00 " out.log || fail "the table lacks the per-light row of A-050E+00"
relight=$(json_num ml.json relight mean)
input=$(json_num ml.json input mean)
n=$(json_num ml.json relight n)
[ "$n" = 10 ] || fail "the relight row has $n scores, expected 2 subjects x 5 lights"
[ "$(json_int ml.json sources_missed)" = 0 ] || fail "a frontal photo was missed"
[ "$(json_int ml.json subjects)" = 2 ] || fail "not two subjects"
[ "$(json_num ml.json light_error_deg n)" -ge 8 ] || fail "the light estimate was scored on fewer than 8 photos"
[ "$(json_num ml.json transfer n)" -ge 8 ] || fail "the transfer was scored fewer than 8 times"
awk -v r="$relight" -v i="$input" 'BEGIN { exit !(r < 0.05 && i > 0.5 && i > 20 * r) }' ||
    fail "relight to the true direction scores $relight against the input's $input: expected about 0"
awk -v t="$(json_num ml.json normals_deg mean)" 'BEGIN { exit !(t > 0 && t < 90) }' || fail "no normals score"
# per subject: a table row each, and in the JSON each subject's 5 relight scores, whose two means
# average to the whole row's mean (each subject has as many)
for who in 001 008; do grep -q "^p$who " out.log || fail "the table lacks the per-subject row of p$who"; done
subject_field() { # subject_field SUBJECT KEY FIELD: in ml.json's per_subject entry of SUBJECT
    awk -v s="\"p$1\"" -v k="\"$2\":" -v f="\"$3\":" '$1 == "\"subject\":" { on = ($2 == s || $2 == s ",") }
        on && $1 == k { in_k = 1 } on && in_k && $1 == f { gsub(/,/, "", $2); print $2; exit }' ml.json
}
r1=$(subject_field 001 relight mean) r2=$(subject_field 008 relight mean)
[ "$(subject_field 001 relight n)" = 5 ] && [ "$(subject_field 008 relight n)" = 5 ] ||
    fail "per subject: the relight rows do not hold 5 scores each"
awk -v a="$r1" -v b="$r2" -v m="$relight" 'BEGIN { d = (a + b) / 2 - m; exit !(a != "" && b != "" && d * d <= 1e-12 + 1e-8 * m * m) }' ||
    fail "per subject: relight means $r1 and $r2 do not average to the row's $relight"
awk -v t="$(subject_field 008 normals_deg mean)" 'BEGIN { exit !(t > 0 && t < 90) }' || fail "per subject: no normals"
for who in 001 008; do exists "sheets/p$who.png"; done
set -- $(png_size sheets/p001.png)
[ "$1" = 532 ] && [ "$2" = 796 ] || fail "sheet is $1 x $2, expected 4 columns x 6 rows of 128 px"

# the azimuths' signs flipped: the same photos under mirrored lights
cp flipped.csv set/lights.csv
expect 0 "$HDNET" eval set --multilight --lights "A-025E+00,A+050E+00,A+000E+45,A-060E-20,A+035E+40" --refs 1 --limit 1 \
    --json
flipped=$(awk '$1 == "\"relight\":" { on = 1 } on && $1 == "\"mean\":" { gsub(/,/, "", $2); print $2; exit }' out.log)
awk -v f="$flipped" -v r="$relight" 'BEGIN { exit !(f > 1 && f > 100 * r) }' ||
    fail "with the azimuths flipped relight scores $flipped (right: $relight): the measure cannot tell"

# a light the set lacks is counted absent, not scored
expect 0 "$HDNET" eval set --multilight --lights "A+000E+45,A+110E+15" --refs 1 --limit 1 --json
grep -q '"photos_absent":	1' out.log || fail "the absent light was not counted"

# bad input: no lights.csv, a listed photo that is not there, bad options
mkdir -p empty
expect_saying 1 "empty/lights.csv" "$HDNET" eval empty --multilight
echo "p001/gone.png,p001,10,10" >> set/lights.csv
expect_saying 1 "gone.png" "$HDNET" eval set --multilight --lights A+010E+10
expect_saying 2 "--lights wants" "$HDNET" eval set --multilight --lights "north"
expect_saying 2 "go with --multilight" "$HDNET" eval set --lights A+000E+00
expect_saying 2 "exclude each other" "$HDNET" eval set --multilight --photos
echo "$TEST: ok (relight $relight, input $input, flipped $flipped)"
