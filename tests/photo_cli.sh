#!/bin/sh
# photo_cli.sh: relight, delight, transfer, estimate-light and decompose on a raw photo (the
# bundled examples/astronaut.png), with a tiny freshly initialised model and, when it exists, the
# shipped one: the output is a photo of the input's size; every pixel away from the face equals
# the input exactly; along the blend boundary the change (output - input) has no step (its
# gradient there is at most 3x that inside the face, where a plain paste would step by the
# whole change, 5-8x); a photo without a face gives exit 1 and a
# message naming it (reported and skipped in a batch); two faces are both done; aligned textures are recognised by their
# companions; transfer = estimate-light + relight --light on photos too. Runs in a scratch folder.
set -u
root=$(cd "$(dirname "$0")/.." && pwd)
HDNET=${HDNET:?HDNET must point at the hdnet tool}
photo="$root/examples/astronaut.png"

TEST=photo_cli
. "$(dirname "$0")/cli_common.shlib"
says() { cat out.log err.log | grep -q -- "$1" || { cat out.log err.log >&2; fail "output does not say '$1'"; }; }

# pfm_pixels FILE: one line per pixel "r g b", in file order (rows bottom to top), header skipped.
pfm_pixels() {
    bytes=$(wc -c <"$1")
    dims=$(head -c 64 "$1" | sed -n 2p)
    w=${dims% *} h=${dims#* }
    od -An -v -tf4 -w12 -j $((bytes - w * h * 12)) "$1"
}

# compare_photos IN.pfm OUT.pfm X0 Y0 X1 Y1: checks that every pixel outside the box equals the
# input exactly and that some inside changed, then measures the step at the edge of the changed
# region: the mean of |d_p - d_q| (d = out - in, RGB length) over 4-neighbour pairs with p changed
# and q not (but where the input itself has an edge between them, a step of its log luminance
# above 0.1: the person's outline against the background, which keeps the photo, as the eval's
# seam), against the same over pairs with both changed. Prints the figures; fails on a violation.
compare_photos() {
    pfm_pixels "$1" >in.txt
    pfm_pixels "$2" >out.txt
    dims=$(head -c 64 "$1" | sed -n 2p)
    paste in.txt out.txt | awk -v W="${dims% *}" -v H="${dims#* }" -v x0="$3" -v y0="$4" -v x1="$5" -v y1="$6" '
    {
        i = NR - 1; x = i % W; y = H - 1 - int(i / W)
        dr = $4 - $1; dg = $5 - $2; db = $6 - $3
        L[x, y] = log(0.2126 * $1 + 0.7152 * $2 + 0.0722 * $3 + 1 / 255)
        if (dr != 0 || dg != 0 || db != 0) {
            changed++
            if (x < x0 || x > x1 || y < y0 || y > y1) { outside++; if (!bad) bad = x "," y }
            c[x, y] = 1; size += sqrt(dr * dr + dg * dg + db * db)
            R[x, y] = dr; G[x, y] = dg; B[x, y] = db # unchanged pixels: d = 0, not stored
        }
    }
    function step(x, y, u, v,    a, b, e) {
        if (!((u, v) in c)) return sqrt(R[x, y] * R[x, y] + G[x, y] * G[x, y] + B[x, y] * B[x, y])
        if (!((x, y) in c)) return step(u, v, x, y)
        a = R[x, y] - R[u, v]; b = G[x, y] - G[u, v]; e = B[x, y] - B[u, v]
        return sqrt(a * a + b * b + e * e)
    }
    function pair(x, y, u, v) {
        if (u < 0 || v < 0 || u >= W || v >= H) return
        if (((x, y) in c) && ((u, v) in c)) { inner += step(x, y, u, v); ninner++ }
        else if (((x, y) in c) != ((u, v) in c)) {
            if (L[x, y] - L[u, v] > 0.1 || L[u, v] - L[x, y] > 0.1) return # the outline
            edge += step(x, y, u, v); nedge++
        }
    }
    END {
        for (k in c) { split(k, p, SUBSEP); x = p[1] + 0; y = p[2] + 0; pair(x, y, x + 1, y); pair(x, y, x, y + 1)
                       if (!((x - 1, y) in c)) pair(x, y, x - 1, y); if (!((x, y - 1) in c)) pair(x, y, x, y - 1) }
        printf "mean change %.4f; ", changed ? size / changed : 0
        printf "changed %d pixels, %d outside the box %d,%d-%d,%d; mean step at the edge %.5f over %d pairs, inside %.5f over %d\n",
            changed, outside, x0, y0, x1, y1, nedge ? edge / nedge : 0, nedge, ninner ? inner / ninner : 0, ninner
        if (outside) { print "a pixel outside the face box changed: " bad; exit 1 }
        if (changed < 1000) { print "fewer than 1000 pixels changed"; exit 1 }
        if (!(edge / nedge <= 3 * inner / ninner)) { print "a seam: the change steps at the edge of the blend"; exit 1 }
    }' >seam.txt
    status=$?
    cat seam.txt
    [ $status -eq 0 ] || fail "$2 against $1: $(tail -1 seam.txt)"
}

expect 0 "$HDNET" init --width 4 --size 32 --seed 1 -o m.safetensors
M="-m m.safetensors"

# The head's box: the face box (from the detector) widened by 60% to either side (the ears, the
# hair) and 80% upward, down to the photo's bottom (the neck): nothing outside may change (the
# background keeps the photo bit for bit; docs/usage.md, "the whole head").
expect 0 "$HDNET" align "$photo" -o aligned --size 64
box=$(sed -n 's/.* box \([0-9.-]*\),\([0-9.-]*\)-\([0-9.-]*\),\([0-9.-]*\) .*/\1 \2 \3 \4/p' out.log | head -1)
[ -n "$box" ] || fail "no box in the align output: $(cat out.log)"
set -- $box
bx0=$(awk -v a="$1" -v b="$3" 'BEGIN { printf "%d", a - 0.6 * (b - a) }')
bx1=$(awk -v a="$1" -v b="$3" 'BEGIN { printf "%d", b + 0.6 * (b - a) }')
by0=$(awk -v a="$2" -v b="$4" 'BEGIN { printf "%d", a - 0.8 * (b - a) }')
by1=1000000

# The input as exact floats: an aligned-texture delight under an all-zero mask gives the input back.
{
    printf 'Pf\n4 4\n-1.0\n'
    head -c 64 /dev/zero
} >zero.pfm
expect 0 "$HDNET" delight "$photo" --aligned --mask zero.pfm $M -o in.pfm

# relight: a photo of the input's size; the face changes, nothing else; no seam
expect 0 "$HDNET" relight "$photo" $M --preset 0 -o relit.pfm
says "relit 1 face"
compare_photos in.pfm relit.pfm "$bx0" "$by0" "$bx1" "$by1"
expect 0 "$HDNET" delight "$photo" $M -o delit.png
says "delit 1 face"
[ "$(png_size delit.png)" = "512 512" ] || fail "delit photo is $(png_size delit.png), expected 512 512"

# every preset, with a sheet: seven photos of the input's size
expect 0 "$HDNET" relight "$photo" $M --preset all -o all --sheet sheet.png
[ "$(png_size all/astronaut.preset0.png)" = "512 512" ] || fail "relit photo is $(png_size all/astronaut.preset0.png), expected 512 512"
for k in 0 1 2 3 4 5 6; do
    [ "$(png_size all/astronaut.preset$k.png)" = "512 512" ] || fail "all/astronaut.preset$k.png is not 512 x 512"
done
exists sheet.png

# transfer onto a photo from a photo = estimate-light + relight --light, byte for byte
expect 0 "$HDNET" transfer "$photo" --ref "$photo" $M -o t.png
expect 0 "$HDNET" estimate-light "$photo" $M -o L.txt --preview L.png
[ "$(grep -c . L.txt)" -eq 9 ] || fail "L.txt does not hold 9 numbers"
expect 0 "$HDNET" relight "$photo" $M --light L.txt -o t2.png
cmp t.png t2.png || fail "photo transfer differs from relight under the estimated light"
[ "$(png_size t.png)" = "512 512" ] || fail "transfer output is not 512 x 512"

# an aligned texture is recognised by its companion mask: relit as a texture, at its own size
tex=aligned/astronaut/face0.png
expect 0 "$HDNET" relight $tex $M --preset 2 -o tex_relit.png
[ "$(png_size tex_relit.png)" = "64 64" ] || fail "the aligned texture was not relit as a texture"
expect 0 "$HDNET" transfer "$photo" --ref $tex $M -o t3.png
[ "$(png_size t3.png)" = "512 512" ] || fail "transfer (aligned reference) output is not 512 x 512"


# two faces in one photo (two 256 x 256 crops of the astronaut side by side, pasted with `hdnet
# blend` through a mask): both relit, both decomposed
LC_ALL=C awk 'BEGIN { printf "Pf\n512 512\n-1.0\n"
    for (r = 0; r < 512; r++) for (x = 0; x < 512; x++)
        if (x >= 100 && x < 356 && 511 - r < 256) printf "%c%c%c%c", 0, 0, 128, 63; else printf "%c%c%c%c", 0, 0, 0, 0 }' >crop.pfm
{
    printf 'Pf\n516 260\n-1.0\n'
    head -c $((516 * 260 * 4)) /dev/zero
} >canvas.pfm
expect 0 "$HDNET" blend -q --source "$photo" --mask crop.pfm --target canvas.pfm --offset -98,2 -o one.png
expect 0 "$HDNET" blend -q --source "$photo" --mask crop.pfm --target one.png --offset 160,2 -o two.png
expect 0 "$HDNET" relight two.png $M --preset 3 -o two_relit.png
says "relit 2 faces"
[ "$(png_size two_relit.png)" = "516 260" ] || fail "the two-face photo relit is $(png_size two_relit.png)"

# a photo without a face: exit 1 naming it; in a batch, reported and skipped
printf '\000\000\000\077' >px # 0.5 as a little-endian float
for i in 1 2 3 4 5 6 7 8 9 10 11 12 13; do cat px px >px2 && mv px2 px; done
{
    printf 'Pf\n96 80\n-1.0\n'
    head -c $((96 * 80 * 4)) px
} >gray.pfm
expect 0 "$HDNET" blend --source gray.pfm --target gray.pfm -o gray.png -q
for cmd in relight delight estimate-light; do
    case $cmd in
    relight) extra="--preset 1 -o x.png" ;;
    delight) extra="-o x.png" ;;
    *) extra="-o x.txt" ;;
    esac
    expect 1 "$HDNET" $cmd gray.png $M $extra
    says "gray.png: no face found"
done
expect 1 "$HDNET" transfer "$photo" --ref gray.png $M -o x.png
says "gray.png: no face found"
expect 1 "$HDNET" decompose gray.png $M -o dec2
says "gray.png: no face found"

# decompose, a folder of photos: the texture-space outputs per face and the reconstructions
# blended into each photo; the photo without a face reported and skipped
mkdir -p batch
cp "$photo" batch/astronaut.png
cp gray.png batch/gray.png
cp two.png batch/two.png
expect 1 "$HDNET" decompose batch $M -o dec
says "gray.png: no face found"
says "1 photo without a face"
d=dec
exists $d/astronaut.face0.albedo.png $d/astronaut.face0.shading.png $d/astronaut.face0.shading.pfm \
    $d/astronaut.face0.normal.png $d/astronaut.face0.light.txt $d/astronaut.face0.recon.png \
    $d/astronaut.face0.sheet.png $d/astronaut.recon.png $d/two.face0.albedo.png $d/two.face1.albedo.png $d/two.recon.png
[ "$(png_size $d/astronaut.face0.albedo.png)" = "32 32" ] || fail "face albedo is not at the model's size"
[ "$(png_size $d/astronaut.recon.png)" = "512 512" ] || fail "the blended reconstruction is not at the photo's size"
# where the person is: the photo's size, the face inside it, the photo's top corners not
exists $d/astronaut.photo.person.png
[ "$(png_size $d/astronaut.photo.person.png)" = "512 512" ] || fail "the person map is not at the photo's size"
/usr/bin/python3 - "$d/astronaut.photo.person.png" <<'PY' || fail "the person map does not hold the face, or holds the corners"
import sys, zlib, struct
data = open(sys.argv[1], "rb").read()
w, h, depth, ctype = struct.unpack(">IIBB", data[16:26])
idat = b"".join(data[i + 8:i + 8 + struct.unpack(">I", data[i:i + 4])[0]]
                for i in range(8, len(data)) if data[i + 4:i + 8] == b"IDAT")
raw = zlib.decompress(idat)
assert depth == 8 and ctype == 0, (depth, ctype)
rows, prev = [], bytearray(w)
for y in range(h):  # PNG filters, one byte a pixel
    f, line = raw[y * (w + 1)], bytearray(raw[y * (w + 1) + 1:(y + 1) * (w + 1)])
    for x in range(w):
        a = line[x - 1] if x else 0
        b, c = prev[x], prev[x - 1] if x else 0
        p = a + b - c
        pred = [0, a, b, (a + b) // 2, a if abs(p - a) <= abs(p - b) and abs(p - a) <= abs(p - c) else b if abs(p - b) <= abs(p - c) else c][f]
        line[x] = (line[x] + pred) & 255
    rows.append(line)
    prev = line
face = rows[127][224]  # the nose tip of the bundled photo
corners = max(rows[2][2], rows[2][w - 3])
print("person map: nose %d, top corners %d" % (face, corners))
sys.exit(0 if face > 240 and corners < 13 else 1)
PY
[ ! -e $d/astronaut.face1.albedo.png ] || fail "a second face in the astronaut photo"
[ ! -e $d/gray.recon.png ] || fail "outputs for the photo without a face"
[ ! -e x.png ] && [ ! -e x.txt ] || fail "a failed command left an output"

# the shipped model, when it is there
if [ -f "$root/models/hdnet-synth.safetensors" ]; then
    expect 0 "$HDNET" relight "$photo" --preset 0 -o shipped.pfm
    compare_photos in.pfm shipped.pfm "$bx0" "$by0" "$bx1" "$by1"
    expect 0 "$HDNET" relight "$photo" --preset 0 -o shipped.png
    [ "$(png_size shipped.png)" = "512 512" ] || fail "relit photo (shipped model) is not 512 x 512"
else
    echo "photo_cli: note: models/hdnet-synth.safetensors is not there; only the tiny model was tried"
fi
echo "photo_cli: all checks passed"
