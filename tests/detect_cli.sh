#!/bin/sh
# detect_cli.sh: `hdnet detect` on a constructed group photo (tests/data/group.jpg, 1200 x 800:
# the bundled faces pasted 40-105 px wide on a cluttered background; their centres and widths in
# tests/data/group.faces.txt): every face is found once and no box lies elsewhere; one pass over
# the whole photo (--min-face 0) misses the small ones; bad --min-face values are usage errors.
set -u
root=$(cd "$(dirname "$0")/.." && pwd)
group="$root/tests/data/group.jpg"
truth="$root/tests/data/group.faces.txt"
TEST=detect_cli
. "$(dirname "$0")/cli_common.shlib"

nfaces=$(grep -vc '^#' "$truth")
expect_saying 0 "1200x800, $nfaces face(s)" "$HDNET" detect "$group" --no-landmarks
# Match boxes to faces: a box shows a face when its centre is within 0.4 face widths of the
# face's and its width within a factor 1.8; each face must be shown by exactly one box, each box
# must show a face.
grep '^face [0-9]*: score' out.log | sed 's/.*box (\([-0-9.]*\), \([-0-9.]*\))-(\([-0-9.]*\), \([-0-9.]*\)).*/\1 \2 \3 \4/' >boxes.txt
[ "$(wc -l <boxes.txt)" -eq "$nfaces" ] || fail "$(wc -l <boxes.txt) boxes for $nfaces faces"
awk 'NR == FNR { if ($1 != "#") { n++; cx[n] = $1; cy[n] = $2; w[n] = $3 }; next }
     { bx = ($1 + $3) / 2; by = ($2 + $4) / 2; bw = $3 - $1; shown = 0
       for (i = 1; i <= n; i++) {
           d = sqrt((bx - cx[i]) ^ 2 + (by - cy[i]) ^ 2)
           if (d < 0.4 * w[i] && bw > w[i] / 1.8 && bw < w[i] * 1.8) { hits[i]++; shown++ }
       }
       if (shown != 1) { print "box " $0 " shows " shown " faces"; bad++ } }
     END { for (i = 1; i <= n; i++) if (hits[i] != 1) { print "face " i " found " hits[i] + 0 " times"; bad++ }
           exit bad > 0 }' "$truth" boxes.txt || fail "boxes and faces do not match one to one"

# With the landmarks (the face mesh keeps every face).
expect_saying 0 "$nfaces face(s)" "$HDNET" detect "$group" --landmarks lm.txt
[ "$(grep -c '^# face' lm.txt)" -eq "$nfaces" ] || fail "landmarks for $(grep -c '^# face' lm.txt) faces"

# One pass over the whole photo finds fewer.
expect 0 "$HDNET" detect "$group" --no-landmarks --min-face 0
one=$(sed -n 's/.*, \([0-9]*\) face(s).*/\1/p' out.log)
[ "$one" -lt "$nfaces" ] || fail "one pass found $one of $nfaces faces: the test does not show the pyramid"

expect_saying 2 "min-face" "$HDNET" detect "$group" --min-face -1
expect_saying 2 "min-face" "$HDNET" detect "$group" --min-face nan
echo "detect_cli: ok ($nfaces faces found once; one pass finds $one)"
