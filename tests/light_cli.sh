#!/bin/sh
# light_cli.sh: the lighting commands end to end (hdnet light, render, fit-light): the issue's Done
# check (patches facing the viewer, right, left, up and down rendered under SPEC section 2's light
# with albedo 0.5 give 0.5 x the test-vector shading within 1/255), render -> fit-light round
# trips, every usage error (exit 2) and bad file (exit 1, message naming the file).
# Inputs are written as PFM by the awk below (exact floats) or made with the tool itself.
set -u
H=${HDNET:?HDNET must point at the hdnet tool}
LC_ALL=C
export LC_ALL

fail() {
    echo "light_cli: $*" >&2
    exit 1
}

# run CODE CMD...: runs CMD, expects exit status CODE (stdout in out.log, stderr in err.log).
run() {
    want=$1
    shift
    "$@" >out.log 2>err.log
    got=$?
    if [ "$got" -ne "$want" ]; then
        cat out.log err.log >&2
        fail "'$*' exited $got, expected $want"
    fi
    if [ "$got" -gt 2 ]; then fail "'$*' died with status $got"; fi
}

# run_msg CODE TEXT CMD...: like run, and stderr must contain TEXT.
run_msg() {
    want=$1
    text=$2
    shift 2
    run "$want" "$@"
    grep -F -- "$text" err.log >/dev/null || { cat err.log >&2; fail "'$*': message lacks '$text'"; }
}

# PFM writer: awk reads "W H C" on the first line and then W*H*C numbers (top row first) and writes
# a little-endian PFM (rows bottom to top, as the format wants).
PFM_AWK='
function f32(v,   s, e, m, bits, i) {
    if (v == 0) { printf "%c%c%c%c", 0, 0, 0, 0; return }
    s = 0; if (v < 0) { s = 1; v = -v }
    e = 0
    while (v >= 2) { v /= 2; e++ }
    while (v < 1) { v *= 2; e-- }
    m = int((v - 1) * 8388608 + 0.5)
    if (m == 8388608) { m = 0; e++ }
    bits = s * 2147483648 + (e + 127) * 8388608 + m
    for (i = 0; i < 4; i++) { printf "%c", bits % 256; bits = int(bits / 256) }
}
NR == 1 { w = $1; h = $2; c = $3; n = 0; next }
{ for (i = 1; i <= NF; i++) val[n++] = $i }
END {
    printf "%s\n%d %d\n-1.0\n", (c == 3 ? "PF" : "Pf"), w, h
    for (y = h - 1; y >= 0; y--)
        for (i = 0; i < w * c; i++) f32(val[y * w * c + i])
}'
pfm() { awk "$PFM_AWK" >"$1"; }

# The last COUNT float32 values of a file, one per line (PFM data; the host is little-endian).
floats() { tail -c $(($2 * 4)) "$1" | od -An -v -tf4 | tr -s ' \t' '\n\n' | sed '/^$/d'; }

# close A B TOL: |A - B| <= TOL
close() { awk -v a="$1" -v b="$2" -v t="$3" 'BEGIN { d = a - b; if (d < 0) d = -d; exit !(d <= t) }'; }

# The light of SPEC section 2 (DPR's rotate_light_00.txt, one number per line as hd_light_write).
cat >dpr00.txt <<'END'
1.084125496282453138
-0.4642676300617166185
0.02837846795150648915
0.6765292733937575687
-0.3594067725393816914
0.04790996460111427574
-0.2280054643781863066
-0.08125983081159608712
0.2881082012687687932
END
# A light of constant shading 1 (l0 = 1 / c0): renders an albedo unchanged, i.e. converts a
# picture to PFM.
printf '1.1283791670955126\n0\n0\n0\n0\n0\n0\n0\n0\n' >one.txt

# ---------------------------------------------------------------- the Done check
# Six pixels in one row: facing the viewer, right, left, up, down, and a zero (masked) pixel.
printf '6 1 3\n0.5 0.5 1  1 0.5 0.5  0 0.5 0.5  0.5 1 0.5  0.5 0 0.5  0 0 0\n' | pfm patches.pfm
printf '6 1 3\n' >a.in
for i in 1 2 3 4 5 6; do echo "0.5 0.5 0.5" >>a.in; done
pfm albedo.pfm <a.in
printf '6 1 3\n' >f.in
for i in 1 2 3 4 5 6; do echo "0.5 0.5 1" >>f.in; done
pfm front.pfm <f.in
expected="1.368747 1.833181 0.448560 0.876864 0.818783 0"

check_patches() { # FILE TOL: the 6 RGB pixels of FILE against 0.5 x the test vectors
    floats "$1" 18 >vals.txt
    i=0
    for s in $expected; do
        for c in 1 2 3; do
            i=$((i + 1))
            v=$(sed -n "${i}p" vals.txt)
            close "$v" "$(awk -v s="$s" 'BEGIN { print 0.5 * s }')" "$2" ||
                fail "$1: pixel $(( (i - 1) / 3 )) channel $c is $v, expected 0.5 x $s (tolerance $2)"
        done
    done
}

run 0 "$H" render --albedo albedo.pfm --normal patches.pfm --light dpr00.txt -o exact.pfm --shading shading.pfm
check_patches exact.pfm 1e-5
floats shading.pfm 6 >s.txt
i=0
for s in $expected; do
    i=$((i + 1))
    close "$(sed -n "${i}p" s.txt)" "$s" 1e-5 || fail "shading.pfm pixel $i is $(sed -n "${i}p" s.txt), expected $s"
done
# the 8-bit PNG output, read back through a constant light
run 0 "$H" render --albedo albedo.pfm --normal patches.pfm --light dpr00.txt -o image.png --shading shading.png
run 0 "$H" render --albedo image.png --normal front.pfm --light one.txt -o image_back.pfm
check_patches image_back.pfm 0.003922
# a normal map stored as an 8-bit PNG (made by rendering its colours under the constant light)
run 0 "$H" render --albedo patches.pfm --normal front.pfm --light one.txt -o patches.png
run 0 "$H" render --albedo albedo.pfm --normal patches.png --light dpr00.txt -o image8.png
run 0 "$H" render --albedo image8.png --normal front.pfm --light one.txt -o image8_back.pfm
check_patches image8_back.pfm 0.003922
# the 16-bit shading PNG holds s/2
run 0 "$H" render --albedo shading.png --normal front.pfm --light one.txt -o shading_back.pfm
floats shading_back.pfm 18 >s.txt
i=0
for s in $expected; do
    v=$(sed -n "$((i * 3 + 1))p" s.txt)
    i=$((i + 1))
    close "$v" "$(awk -v s="$s" 'BEGIN { print s / 2 }')" 2e-5 || fail "shading.png pixel $i is $v, expected $s / 2"
done
# an explicit mask: pixel 2 (left) masked out
printf '6 1 1\n1 1 0 1 1 1\n' | pfm mask.pfm
run 0 "$H" render --albedo albedo.pfm --normal patches.pfm --light dpr00.txt --mask mask.pfm -o masked.pfm
floats masked.pfm 18 >m.txt
[ "$(sed -n 7p m.txt)" = "0" ] || fail "masked pixel rendered as $(sed -n 7p m.txt)"
close "$(sed -n 4p m.txt)" 0.9165905 1e-5 || fail "unmasked pixel changed by the mask"

# ---------------------------------------------------------------- fit-light round trips
# A 40x40 sphere of normals (0 outside), rendered under the DPR light, fitted back.
awk 'BEGIN {
    n = 40; print n, n, 3
    for (y = 0; y < n; y++) for (x = 0; x < n; x++) {
        u = (2 * x + 1) / n - 1; v = 1 - (2 * y + 1) / n; r = u * u + v * v
        if (r < 0.95) print (u + 1) / 2, (v + 1) / 2, (sqrt(1 - r) + 1) / 2; else print 0, 0, 0
    }
}' | pfm sphere_n.pfm
awk 'BEGIN { n = 40; print n, n, 3; for (i = 0; i < n * n; i++) print 0.5, 0.4, 0.25 }' | pfm sphere_a.pfm
run 0 "$H" render --albedo sphere_a.pfm --normal sphere_n.pfm --light dpr00.txt -o sphere_i.pfm --shading sphere_s.pfm

# compare_light FILE TOL [REF]: FILE's 9 numbers against REF (default dpr00.txt)
compare_light() {
    paste "$1" "${3:-dpr00.txt}" | awk -v t="$2" -v f="$1" '{ d = $1 - $2; if (d < 0) d = -d; if (d > t) { print f ": coefficient " NR " is " $1 ", expected " $2; bad = 1 } } END { exit bad }' >&2 ||
        fail "$1 does not recover the light within $2"
    [ "$(wc -l <"$1")" -eq 9 ] || fail "$1 does not hold 9 lines"
}
run 0 "$H" fit-light --normal sphere_n.pfm --shading sphere_s.pfm -o fit_exact.txt
compare_light fit_exact.txt 1e-4
grep -F "rms residual" out.log >/dev/null || fail "fit-light prints no residual"
grep -F "light: 1.084" out.log >/dev/null || fail "fit-light does not print the coefficients: $(cat out.log)"
run 0 "$H" fit-light --normal sphere_n.pfm --image sphere_i.pfm --albedo sphere_a.pfm -o fit_image.txt
compare_light fit_image.txt 1e-4
# a mask keeping the right half still recovers it
awk 'BEGIN { n = 40; print n, n, 1; for (y = 0; y < n; y++) for (x = 0; x < n; x++) print (x >= 20 ? 1 : 0) }' |
    pfm half.pfm
run 0 "$H" fit-light --normal sphere_n.pfm --shading sphere_s.pfm --mask half.pfm -o fit_half.txt
compare_light fit_half.txt 1e-3
# a light from a direction, rendered and fitted, is the same light; through the 16-bit shading PNG
# and the 8-bit image too (this light's shading stays below 2, so nothing is clipped)
run 0 "$H" light --dir 30,-20 --intensity 1.2 --ambient 0.4 -o dir.txt
run 0 "$H" render --albedo sphere_a.pfm --normal sphere_n.pfm --light dir.txt -o dir_i.pfm --shading dir_s.pfm
run 0 "$H" fit-light --normal sphere_n.pfm --shading dir_s.pfm -o dir_fit.txt
compare_light dir_fit.txt 1e-4 dir.txt
run 0 "$H" render --albedo sphere_a.pfm --normal sphere_n.pfm --light dir.txt -o dir_i.png --shading dir_s.png
run 0 "$H" fit-light --normal sphere_n.pfm --shading dir_s.png -o dir_fit16.txt
compare_light dir_fit16.txt 1e-3 dir.txt
run 0 "$H" fit-light --normal sphere_n.pfm --image dir_i.png --albedo sphere_a.pfm -o dir_fit8.txt
compare_light dir_fit8.txt 0.01 dir.txt

# ---------------------------------------------------------------- hdnet light
run 0 "$H" light --dir 0,0 --intensity 0 --ambient 0.8 -o amb.txt
close "$(head -1 amb.txt)" 0.90270333 1e-6 || fail "ambient 0.8 gives l0 = $(head -1 amb.txt), expected 0.8 / c0"
[ "$(sed -n 2,9p amb.txt | tr -d '\n-')" = "00000000" ] || fail "ambient-only light has non-zero higher terms"
k=0
while [ $k -lt 7 ]; do
    run 0 "$H" light --preset $k -o preset$k.txt
    [ "$(wc -l <preset$k.txt)" -eq 9 ] || fail "preset $k is not 9 lines"
    j=0
    while [ $j -lt $k ]; do
        cmp -s preset$j.txt preset$k.txt && fail "presets $j and $k are the same"
        j=$((j + 1))
    done
    k=$((k + 1))
done
run 0 "$H" light --preset 3 -o p3.txt --preview p3.png --size 32
run 0 "$H" light --show dpr00.txt -o dpr00.png --size 48
run 0 "$H" light --presets -o presets.png --size 24
run 0 "$H" light --dir 45,30 -o d.txt --preview d.png
for f in p3.png dpr00.png presets.png d.png; do
    [ "$(head -c 4 $f | od -An -tx1 | tr -d ' ')" = "89504e47" ] || fail "$f is not a PNG"
done
# the sphere, read back: a 1-pixel sphere is the normal toward the viewer, shown as s/2
run 0 "$H" light --show dpr00.txt -o dpr00_1.png --size 1
awk 'BEGIN { print 1, 1, 3; print 0.5, 0.5, 1 }' | pfm front1.pfm
run 0 "$H" render --albedo dpr00_1.png --normal front1.pfm --light one.txt -o centre.pfm
close "$(floats centre.pfm 3 | head -1)" 0.6843735 0.0021 || fail "sphere centre is $(floats centre.pfm 3 | head -1)"
run 0 "$H" light --help
grep -F -- "--dir" out.log >/dev/null || fail "light --help does not list --dir"
run 0 "$H" render --help
run 0 "$H" fit-light --help

# ---------------------------------------------------------------- usage errors (exit 2)
run 2 "$H" light
run 2 "$H" light -o x.txt
run 2 "$H" light --dir 10 -o x.txt
run 2 "$H" light --dir 10,20,30 -o x.txt
run 2 "$H" light --dir a,b -o x.txt
run 2 "$H" light --dir 10,20 --preset 1 -o x.txt
run 2 "$H" light --preset 1 --show dpr00.txt -o x.txt
run 2 "$H" light --preset 1
run 2 "$H" light --preset 7 -o x.txt
run 2 "$H" light --preset -1 -o x.txt
run 2 "$H" light --preset one -o x.txt
run 2 "$H" light --preset 1 --intensity 2 -o x.txt
run 2 "$H" light --dir 0,91 -o x.txt
run 2 "$H" light --dir 0,0 --intensity -1 -o x.txt
run 2 "$H" light --dir 0,0 --ambient nan -o x.txt
run 2 "$H" light --show dpr00.txt -o x.png --preview y.png
run 2 "$H" light --preset 0 -o x.txt --size 0
run 2 "$H" light --preset 0 -o x.txt --size 5000
run 2 "$H" light --preset 0 -o x.txt extra
run 2 "$H" light --bogus
run 2 "$H" render --albedo albedo.pfm --normal patches.pfm -o x.png
run 2 "$H" render --albedo albedo.pfm --light dpr00.txt -o x.png
run 2 "$H" render --normal patches.pfm --light dpr00.txt -o x.png
run 2 "$H" render --albedo albedo.pfm --normal patches.pfm --light dpr00.txt
run 2 "$H" render --albedo albedo.pfm --normal patches.pfm --light dpr00.txt -o x.png --frobnicate
run 2 "$H" fit-light --normal sphere_n.pfm -o x.txt
run 2 "$H" fit-light --normal sphere_n.pfm --shading sphere_s.pfm --image sphere_i.pfm --albedo sphere_a.pfm -o x.txt
run 2 "$H" fit-light --normal sphere_n.pfm --image sphere_i.pfm -o x.txt
run 2 "$H" fit-light --normal sphere_n.pfm --albedo sphere_a.pfm -o x.txt
run 2 "$H" fit-light --shading sphere_s.pfm -o x.txt
run 2 "$H" fit-light --normal sphere_n.pfm --shading sphere_s.pfm
[ -e x.txt ] || [ -e x.png ] && fail "a usage error left an output file"

# ---------------------------------------------------------------- bad files (exit 1)
printf '1 2 3\n4 five 6\n7 8 9\n' >bad_text.txt
printf '1 2 3\n4 5 6\n7 8\n' >bad_short.txt
printf '1 2 3\n4 5 6\n7 8 9\n10\n' >bad_long.txt
printf '1 2 3\nnan 5 6\n7 8 9\n' >bad_nan.txt
printf '1 2 3\n4 5 6\n7 8 -inf\n' >bad_inf.txt
printf 'not an image at all' >junk.png
printf '\211PNG\r\n\032\n\000\000\000\rIHDR' >truncated.png
run_msg 1 "bad_text.txt:2:" "$H" light --show bad_text.txt -o x.png
run_msg 1 "bad_short.txt:3:" "$H" render --albedo albedo.pfm --normal patches.pfm --light bad_short.txt -o x.png
run_msg 1 "bad_long.txt:4:" "$H" render --albedo albedo.pfm --normal patches.pfm --light bad_long.txt -o x.png
run_msg 1 "bad_nan.txt:2:" "$H" light --show bad_nan.txt -o x.png
run_msg 1 "bad_inf.txt:3:" "$H" light --show bad_inf.txt -o x.png
run_msg 1 "missing.txt" "$H" light --show missing.txt -o x.png
run_msg 1 "junk.png" "$H" render --albedo junk.png --normal patches.pfm --light dpr00.txt -o x.png
run_msg 1 "truncated.png" "$H" render --albedo albedo.pfm --normal truncated.png --light dpr00.txt -o x.png
run_msg 1 "missing.png" "$H" render --albedo albedo.pfm --normal missing.png --light dpr00.txt -o x.png
run_msg 1 "same size" "$H" render --albedo sphere_a.pfm --normal patches.pfm --light dpr00.txt -o x.png
run_msg 1 "same size" "$H" render --albedo albedo.pfm --normal patches.pfm --light dpr00.txt --mask half.pfm -o x.png
run_msg 1 "no/such/dir" "$H" render --albedo albedo.pfm --normal patches.pfm --light dpr00.txt -o no/such/dir/x.png
run_msg 1 "no/such/dir" "$H" light --preset 2 -o no/such/dir/x.txt
run_msg 1 "no/such/dir" "$H" light --preset 2 -o ok.txt --preview no/such/dir/x.png
run_msg 1 "same size" "$H" fit-light --normal patches.pfm --shading sphere_s.pfm -o x.txt
run_msg 1 "same size" "$H" fit-light --normal sphere_n.pfm --image sphere_i.pfm --albedo albedo.pfm -o x.txt
run_msg 1 "junk.png" "$H" fit-light --normal junk.png --shading sphere_s.pfm -o x.txt
run_msg 1 "junk.png" "$H" fit-light --normal sphere_n.pfm --shading junk.png -o x.txt
awk 'BEGIN { print 4, 4, 3; for (i = 0; i < 16; i++) print 0, 0, 0 }' | pfm zero_n.pfm
awk 'BEGIN { print 4, 4, 1; for (i = 0; i < 16; i++) print 1 }' | pfm ones.pfm
run_msg 1 "no pixel" "$H" fit-light --normal zero_n.pfm --shading ones.pfm -o x.txt
# a shading with NaN where it counts
awk 'BEGIN { print 1, 1, 3; print 0.5, 0.5, 1 }' | pfm one_n.pfm
printf 'Pf\n1 1\n-1.0\n\000\000\300\177' >nan_s.pfm
run 1 "$H" fit-light --normal one_n.pfm --shading nan_s.pfm -o x.txt
[ -e x.txt ] || [ -e x.png ] && fail "a failed command left an output file"
ls | grep -F '.tmp.' && fail "a temporary file was left behind"
exit 0
