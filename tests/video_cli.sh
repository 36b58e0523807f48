#!/bin/sh
# video_cli.sh: relight, delight and transfer on clips from the command line: a folder of frames
# (--fps; needs no FFmpeg) gives a folder of as many relit frames; with FFmpeg in the build, a
# folder to a video file, video to video (delight), transfer with a reference photo; a build without
# FFmpeg says how to get it and the test skips (exit 77): the video files were not tested. The
# background relit changes every frame, and a frame without a face holds the wall's change. Bad --fps and --background values and a clip with --preset all are usage errors; a
# broken video file is reported and leaves no output.
set -u
root=$(cd "$(dirname "$0")/.." && pwd)
photo="$root/examples/astronaut.png"
TEST=video_cli
. "$(dirname "$0")/cli_common.shlib"

mkdir -p frames
for i in 0 1 2; do cp "$photo" "frames/f$i.png"; done
expect_saying 0 "3 frames (3 with a face)" "$HDNET" relight frames --fps 10 --preset 3 -o relit
[ "$(ls relit | wc -l)" -eq 3 ] || fail "relit/ has $(ls relit | wc -l) frames, expected 3"
[ "$(png_size relit/frame000002.png)" = "512 512" ] || fail "relit frame is not 512 x 512"
grep -q "(smoothed)" out.log || fail "the clip was not smoothed: $(cat out.log)"
expect_saying 0 "3 frames" "$HDNET" delight frames --fps 10 --no-smooth -o delit
grep -q "(smoothed)" out.log && fail "--no-smooth still smoothed"

# the background relit as a wall (the frame's pixels: tests/test_video.c): every frame differs
expect_saying 0 "3 frames (3 with a face)" "$HDNET" relight frames --fps 10 --preset 3 --background relight -o wall
for i in 0 1 2; do
    cmp -s "relit/frame00000$i.png" "wall/frame00000$i.png" && fail "frame $i: --background relight changed nothing"
done
# a frame without a face between two with one (black, so its pixels stay; the wall's held change
# itself: tests/test_video.c): with the background relit it takes the wall's change of the frame
# before and says so; with the background kept the summary is as before
mkdir -p gap
cp "$photo" gap/f0.png
cp "$photo" gap/f2.png
printf 'Pf\n512 512\n-1.0\n' >gap/f1.pfm
head -c $((512 * 512 * 4)) /dev/zero >>gap/f1.pfm
expect_saying 0 "3 frames (2 with a face, 1 with the wall held)" "$HDNET" relight gap --fps 10 --preset 3 --background relight -o gapwall
expect_saying 0 "3 frames (2 with a face)," "$HDNET" relight gap --fps 10 --preset 3 -o gapkeep
expect_saying 2 "keep or relight" "$HDNET" delight frames --fps 10 --background wall -o bad
expect_saying 2 "fps" "$HDNET" relight frames --fps -1 --preset 3 -o bad
expect_saying 2 "fps" "$HDNET" relight frames --fps 5000 --preset 3 -o bad
expect_saying 2 "one light" "$HDNET" relight frames --fps 10 --preset all -o bad
[ ! -e bad ] || fail "a usage error wrote output"

"$HDNET" relight frames --fps 10 --preset 3 -o probe.mp4 >out.log 2>err.log
if grep -q "no video support" err.log; then
    grep -q "apt-get install libavformat-dev" err.log || fail "the message does not say how to get video: $(cat err.log)"
    [ ! -e probe.mp4 ] || fail "probe.mp4 written without video support"
    skip "this build has no FFmpeg (libavformat-dev, libavcodec-dev, libswscale-dev): video files not tested"
fi
grep -q "3 frames (3 with a face)" out.log || fail "frames to video: $(cat out.log err.log)"
exists probe.mp4
expect_saying 0 "probe.mp4 -> delit.mkv: 3 frames (3 with a face)" "$HDNET" delight probe.mp4 -o delit.mkv
exists delit.mkv
expect_saying 0 "3 frames (3 with a face)" "$HDNET" transfer probe.mp4 --ref "$photo" -o transfer.mp4
exists transfer.mp4
# and back to frames
expect_saying 0 "3 frames" "$HDNET" relight transfer.mp4 --preset 1 -o back
[ "$(ls back | wc -l)" -eq 3 ] || fail "back/ has $(ls back | wc -l) frames"

printf 'not a video\n' >broken.mp4
expect_saying 1 "broken.mp4" "$HDNET" relight broken.mp4 --preset 3 -o broken_out.mp4
[ ! -e broken_out.mp4 ] || fail "a failed clip left output"
ls | grep -q '\.tmp' && fail "a temporary file was left: $(ls)"
echo "video_cli: ok"
