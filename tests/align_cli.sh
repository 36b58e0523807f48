#!/bin/sh
# align_cli.sh: `hdnet align` and `hdnet blend` from the command line: the bundled photo gives one
# face and its five files; a photo without a face, a tiny one, a huge one and bad paths give clear
# messages and the documented exit codes; a texture warps back and blends into the photo.
set -u
root=$(cd "$(dirname "$0")/.." && pwd)
photo="$root/examples/astronaut.png"
TEST=align_cli
. "$(dirname "$0")/cli_common.shlib"
# A black PFM photo of W x H (gray): header, then W*H little-endian float zeros.
black_pfm() {
    printf 'Pf\n%d %d\n-1.0\n' "$2" "$3" >"$1"
    head -c $(($2 * $3 * 4)) /dev/zero >>"$1"
}

black_pfm black.pfm 256 256
mkdir -p batch
cp "$photo" batch/astronaut.png
expect_saying 0 "blended" "$HDNET" blend --source black.pfm --target black.pfm -o batch/black.png

# a folder with the bundled photo (exactly one face, five files) and a face-less photo (reported,
# not an error for the batch)
expect_saying 1 "2 photos -> aligned: 1 done (1 face), 1 without a face, 0 failed" "$HDNET" align batch -o aligned --size 128
grep -q "batch/black.png: no face found" err.log || fail "the face-less photo was not reported: $(cat err.log)"
for f in face0.png face0.mask.png face0.normal.png face0.landmarks.txt face0.warp.txt; do
    [ -s "aligned/astronaut/$f" ] || fail "aligned/astronaut/$f is missing"
done
[ ! -e aligned/astronaut/face1.png ] || fail "more than one face in the astronaut photo"
[ ! -e aligned/black ] || fail "a folder was written for the face-less photo"
[ "$(wc -l <aligned/astronaut/face0.landmarks.txt)" -eq 468 ] || fail "landmarks file is not 468 lines"
head -1 aligned/astronaut/face0.warp.txt | grep -q '^hdnet-warp 1$' || fail "warp file has no header"
grep -q '^size 128$' aligned/astronaut/face0.warp.txt || fail "warp file does not record --size 128"

# no face, tiny, huge, one photo each: exit 1 when nothing at all was found
expect_saying 1 "black.pfm: no face found" "$HDNET" align black.pfm -o none
black_pfm tiny.pfm 8 8
expect_saying 1 "tiny.pfm: no face found" "$HDNET" align tiny.pfm -o none
printf 'PF\n40000 40000\n-1.0\n' >huge.pfm
expect_saying 1 "huge.pfm" "$HDNET" align huge.pfm -o none

# bad paths and bad options
expect_saying 1 "no-such.png" "$HDNET" align no-such.png -o x
expect_saying 2 "-o DIR is required" "$HDNET" align "$photo"
expect_saying 2 "--size" "$HDNET" align "$photo" -o x --size 8
expect_saying 1 "/dev/null/x" "$HDNET" align "$photo" -o /dev/null/x
mkdir -p empty
expect_saying 1 "empty: no .png/.jpg/.jpeg image in the folder" "$HDNET" align empty -o x

# blend: the face's own texture warped back (round trip), an offset paste, errors
a=aligned/astronaut
expect_saying 0 "relative residual" "$HDNET" blend --source $a/face0.png --mask $a/face0.mask.png --warp $a/face0.warp.txt \
    --target "$photo" -o roundtrip.png
[ -s roundtrip.png ] || fail "blend wrote no output"
expect_saying 0 "relative residual" "$HDNET" blend --source $a/face0.png --mask $a/face0.mask.png --warp $a/face0.warp.txt \
    --original $a/face0.png --target "$photo" -o change.png
expect_saying 2 "--original goes with --warp" "$HDNET" blend --source $a/face0.png --original $a/face0.png --target "$photo" -o x.png
expect_saying 1 "says the aligned texture is 128x128" "$HDNET" blend --source $a/face0.png --warp $a/face0.warp.txt \
    --original "$photo" --target "$photo" -o x.png
expect_saying 0 "relative residual" "$HDNET" blend --source $a/face0.png --mask $a/face0.mask.png --target "$photo" \
    --offset 300,300 -o pasted.png
expect_saying 1 "the mask must be source-sized" "$HDNET" blend --source $a/face0.png --mask "$photo" --target "$photo" -o x.png
expect_saying 1 "aligned from a 512x512 photo" "$HDNET" blend --source $a/face0.png --warp $a/face0.warp.txt --target black.pfm -o x.png
printf 'hdnet-warp 1\nphoto 512 512\nsize abc\n' >bad.warp.txt
expect_saying 1 "bad.warp.txt:3" "$HDNET" blend --source $a/face0.png --warp bad.warp.txt --target "$photo" -o x.png
expect_saying 2 "--source is required" "$HDNET" blend --target "$photo" -o x.png
expect_saying 2 "exclude each other" "$HDNET" blend --source $a/face0.png --target "$photo" --warp $a/face0.warp.txt --offset 1,2 -o x.png
[ ! -e x.png ] || fail "a failed blend left an output"
exit 0
