#!/bin/sh
# reliability_cli.sh: issue 15's defects, each checked through the tool (docs/reliability.md):
# symlinks planted at output paths and at the old guessable temporaries are never followed;
# non-finite results (huge lights, a 3e38 PFM, --w-adv 1e38) give exit 1 and no output; the PFM
# bomb is refused in bounded memory (ulimit -v, 400 MB) and the tool runs there; the pixel limit and HDNET_MAX_PIXELS; two trains
# into one folder; a failed train leaves no header-only loss.csv; stale temporaries of dead
# processes are removed on start; control bytes of input are printed escaped.
set -u
H=${HDNET:?HDNET is not set}
TEST=reliability_cli
. "$(dirname "$0")/cli_common.shlib"

# no_file F...: none of the files exists (not even as a dangling link)
no_file() { for f in "$@"; do { [ -e "$f" ] || [ -L "$f" ]; } && fail "$f exists"; done; return 0; }
# untouched: the symlinks' target still holds what it held
untouched() { [ "$(cat target.txt)" = "precious" ] || fail "the symlink's target was overwritten ($*)"; }
# no_temporaries DIR: no "*.tmp.*" file is left below DIR
no_temporaries() {
    left=$(find "$1" -name '*.tmp.*' | head -3)
    [ -z "$left" ] || fail "temporaries left in $1: $left"
}

echo precious >target.txt
expect 0 $H synth data --subjects 2 --per-subject 2 --size 32 --seed 4 --threads 1
S=data/subject_0000/0000
expect 0 $H init --width 4 --size 32 --seed 3 -o model.safetensors

# ---------------------------------------------------------------- 1. symlinks
# A link at the output path itself: refused, the target untouched, the link left as it was.
for cmd in "light --dir 30,10 -o OUT.txt" "light --show $S.light.txt -o OUT.png" "light --presets -o OUT.png" \
           "init --width 4 --size 32 --seed 1 -o OUT.safetensors" \
           "render --albedo $S.albedo.png --normal $S.normal_gt.png --light $S.light.txt -o OUT.png" \
           "estimate-light $S.png -m model.safetensors -o OUT.txt" \
           "relight $S.png --aligned -m model.safetensors --preset 1 -o OUT.png" \
           "delight $S.png --aligned -m model.safetensors -o OUT.png"; do
    out=$(echo "$cmd" | sed 's/.* -o //')
    rm -f "$out"
    ln -s target.txt "$out"
    # shellcheck disable=SC2086
    expect 1 $H $cmd
    grep -q "symbolic link" err.log || fail "'$cmd' through a link: $(cat err.log)"
    untouched "$cmd"
    [ -L "$out" ] || fail "'$cmd' replaced the link"
    rm -f "$out"
done
rm -f OUT
# every file decompose writes for an image, one at a time: the link makes the whole set fail
for suffix in albedo.png shading.png shading.pfm normal.png light.txt recon.png sheet.png; do
    rm -rf dec && mkdir dec && ln -s ../target.txt "dec/0000.$suffix"
    expect 1 $H decompose "$S.png" --aligned -m model.safetensors -o dec
    untouched "decompose NAME.$suffix"
    [ "$(find dec -type f | wc -l)" = 0 ] || fail "decompose wrote part of a set beside the link at $suffix: $(ls dec)"
done
# render's second output (--shading) through a link: neither file is written
ln -s target.txt shading_link.png
expect 1 $H render --albedo $S.albedo.png --normal $S.normal_gt.png --light $S.light.txt -o r.png --shading shading_link.png
untouched "render --shading"
no_file r.png
# a video file (the muxer writes into the same kind of temporary): refused through a link
mkdir -p frames && cp "$S.png" frames/f0.png && cp "$S.png" frames/f1.png
ln -s target.txt clip_link.mp4
$H relight frames --fps 5 --preset 1 -m model.safetensors -o clip_link.mp4 >out.log 2>err.log
if grep -q "no video support" err.log; then
    echo "reliability_cli: this build has no FFmpeg: the video output's link not tested"
else
    grep -q "symbolic link" err.log || fail "relight to a video through a link: $(cat out.log err.log)"
    untouched "relight -o clip_link.mp4"
    [ -L clip_link.mp4 ] || fail "the video writer replaced the link"
    expect 0 $H relight frames --fps 5 --preset 1 -m model.safetensors -o clip.mp4
    [ -f clip.mp4 ] && [ ! -L clip.mp4 ] || fail "relight -o clip.mp4 wrote no regular file"
    no_temporaries .
fi
# the files of a run folder
for f in loss.csv model.safetensors checkpoint.safetensors loss.png; do
    rm -rf run && mkdir run && ln -s ../target.txt "run/$f"
    expect 1 $H train data -o run --size 32 --width 4 --batch 1 --threads 1 -q --iters 2 --every 2
    untouched "train run/$f"
done
# The old temporary names ("OUT.tmp.PID": the PID is known to a shell that execs the tool) and
# links at a thousand names of that form: never opened, the output is a regular file.
for cmd in "light --dir 30,10 -o out.txt" "init --width 4 --size 32 --seed 1 -o out.txt"; do
    rm -f out.txt out.txt.tmp.*
    # shellcheck disable=SC2016
    sh -c 'i=0; while [ $i -lt 20 ]; do ln -s target.txt "out.txt.tmp.$(($$ + i))"; i=$((i + 1)); done; exec "$@"' \
        sh $H $cmd >out.log 2>err.log || fail "'$cmd' with planted temporaries: $(cat err.log)"
    untouched "$cmd temporaries"
    [ -f out.txt ] && [ ! -L out.txt ] || fail "'$cmd': out.txt is not a regular file"
    [ "$(find . -maxdepth 1 -name 'out.txt.tmp.*' -type f | wc -l)" = 0 ] || fail "'$cmd' left a temporary"
done
# the mode: 0644 under the umask
(umask 077 && $H light --dir 30,10 -o private.txt) || fail "light -o private.txt"
[ "$(stat -c %a private.txt)" = 600 ] || fail "umask 077 gave mode $(stat -c %a private.txt)"
(umask 022 && $H light --dir 30,10 -o public.txt) || fail "light -o public.txt"
[ "$(stat -c %a public.txt)" = 644 ] || fail "umask 022 gave mode $(stat -c %a public.txt)"

# ---------------------------------------------------------------- 2. non-finite results
printf '3.4e38\n0\n0\n0\n0\n0\n0\n0\n0\n' >huge.light.txt
expect_saying 1 "out of range" $H render --albedo $S.albedo.png --normal $S.normal_gt.png --light huge.light.txt \
    -o huge.pfm --shading huge_s.pfm
no_file huge.pfm huge_s.pfm
expect_saying 1 "out of range" $H light --show huge.light.txt -o huge_sphere.png
no_file huge_sphere.png
expect_saying 2 "overflow" $H relight $S.png --aligned -m model.safetensors --dir 0,0 --intensity 1e37 -o huge_relit.png
no_file huge_relit.png
# a 32x32 RGB PFM of 3e38 (finite, but everything computed from it overflows)
{ printf 'PF\n32 32\n-1.0\n'; i=0; while [ $i -lt 3072 ]; do printf '\346\261\141\177'; i=$((i + 1)); done; } >big.pfm
cp data/subject_0000/0000.mask.png big.mask.png
printf '10\n0\n0\n0\n0\n0\n0\n0\n0\n' >one.light.txt
expect_saying 1 "not finite" $H render --albedo big.pfm --normal $S.normal_gt.png --light one.light.txt -o big_r.pfm --shading big_s.pfm
grep -q "big.pfm" err.log || fail "render's non-finite error does not name the input: $(cat err.log)"
no_file big_r.pfm big_s.pfm
mkdir -p decbig
expect 1 $H decompose big.pfm -m model.safetensors -o decbig
grep -q "big.pfm.*not finite" err.log || fail "decompose of a 3e38 PFM: $(cat err.log)"
[ "$(find decbig -type f | wc -l)" = 0 ] || fail "decompose of a 3e38 PFM wrote $(ls decbig)"
# training with a loss beyond float: stops, no row of it in loss.csv, no header-only loss.csv
expect 1 $H train data -o advrun --size 32 --width 4 --batch 1 --threads 1 -q --iters 3 --every 1 --w-adv 1e38
grep -q "not finite" err.log || fail "--w-adv 1e38: $(cat err.log)"
no_file advrun/loss.csv advrun/samples advrun/model.safetensors

# ---------------------------------------------------------------- 3. bounded memory
{ printf 'PF\n16384 16384\n-1.0\n'; printf '%064d' 0; } >bomb.pfm
# (under ASan, `make check`, the address-space limit is left out: the sanitizer's shadow memory
# reserves terabytes of address space; the message is still checked)
vlimit="ulimit -v 400000 &&"
[ -n "${HD_CHECK:-}" ] && vlimit=""
sh -c "$vlimit HDNET_MAX_PIXELS=300000000 exec timeout 60 $H info bomb.pfm" >out.log 2>err.log
[ $? = 1 ] || fail "PFM bomb: $(cat err.log)"
grep -q "bomb.pfm.*truncated" err.log || fail "PFM bomb not refused from its size: $(cat err.log)"
# the tool starts and ends under 400 MB of address space (OpenBLAS's worker threads used to retry
# their 128 MB buffers forever there: it hung)
if [ -z "${HD_CHECK:-}" ]; then
    sh -c "ulimit -v 400000 && exec timeout 60 $H light --dir 30,10 -o limited.txt" >out.log 2>err.log ||
        fail "light under ulimit -v 400000 (exit $?): $(cat err.log)"
fi
HDNET_MAX_PIXELS=1000 $H info $S.png >out.log 2>err.log && fail "HDNET_MAX_PIXELS=1000 accepted a 32x32 image"
grep -q "0000.png.*limit of 1000 pixels.*HDNET_MAX_PIXELS" err.log || fail "pixel limit message: $(cat err.log)"
HDNET_MAX_PIXELS=1024 $H info $S.png >out.log 2>err.log || fail "HDNET_MAX_PIXELS=1024 refused 32x32: $(cat err.log)"
# the same limit as an option before the command, over the environment variable
$H --max-pixels 1000 info $S.png >out.log 2>err.log && fail "--max-pixels 1000 accepted a 32x32 image"
grep -q "0000.png.*limit of 1000 pixels" err.log || fail "--max-pixels message: $(cat err.log)"
HDNET_MAX_PIXELS=1000 $H --max-pixels 1024 info $S.png >out.log 2>err.log || fail "--max-pixels 1024 refused 32x32: $(cat err.log)"
expect 2 $H --max-pixels 0 info $S.png
expect 2 $H --max-pixels 12abc info $S.png
expect 2 $H --max-pixels

# ---------------------------------------------------------------- 4. stale temporaries
mkdir -p stale
# a PID that is not running: the largest possible one is never handed out here
dead=$(cat /proc/sys/kernel/pid_max)
# temporaries carry the host's name (every byte but A-Za-z0-9- as _, at most 64)
host=$(printf %s "$(uname -n)" | tr -c 'A-Za-z0-9-' _ | cut -c1-64)
: >"stale/0000.albedo.png.tmp.$host.$dead.0123456789abcdef"
: >"stale/0000.albedo.png.tmp.$host.$$.0123456789abcdef"        # a live process's: kept
: >"stale/0000.normal.png.tmp.other-$host.$dead.0123456789abcdef" # another host's: kept
: >"stale/notes.tmp.txt"                                          # not ours: kept
expect 0 $H decompose "$S.png" --aligned -m model.safetensors -o stale
no_file "stale/0000.albedo.png.tmp.$host.$dead.0123456789abcdef"
[ -f "stale/0000.albedo.png.tmp.$host.$$.0123456789abcdef" ] && [ -f stale/notes.tmp.txt ] &&
    [ -f "stale/0000.normal.png.tmp.other-$host.$dead.0123456789abcdef" ] ||
    fail "decompose removed a file that is not a dead process's temporary of this host"
expect 0 $H train data -o srun --size 32 --width 4 --batch 1 --threads 1 -q --iters 1 --every 1
: >"srun/checkpoint.safetensors.tmp.$host.$dead.fedcba9876543210"
: >"srun/samples/iter_0000001.png.tmp.$host.$dead.fedcba9876543210"
expect 0 $H train data -o srun --threads 1 -q --iters 2 --every 1 --resume
no_temporaries srun

# ---------------------------------------------------------------- 5. one writer per run folder
$H train data -o lrun --size 32 --width 4 --batch 1 --threads 1 -q --iters 100000 --every 100000 >first.log 2>&1 &
first=$!
i=0
while [ ! -f lrun/loss.csv ] && [ $i -lt 300 ]; do sleep 0.1; i=$((i + 1)); done
expect_saying 1 "another hdnet process" $H train data -o lrun --size 32 --width 4 --batch 1 --threads 1 -q --iters 2
kill -INT $first
wait $first
expect 0 $H train data -o lrun --threads 1 -q --iters 1 --resume

# ---------------------------------------------------------------- 6. terminal escapes
printf '1 2 3 4 \033[31mred 6 7 8 9\n' >esc.light.txt
expect 1 $H render --albedo $S.albedo.png --normal $S.normal_gt.png --light esc.light.txt -o esc.png
grep -q 'x1b\[31mred' err.log || fail "the escape byte is not shown as \\x1b: $(cat err.log)"
if grep -q "$(printf '\033')" err.log; then fail "a raw escape byte reached stderr"; fi

# a tensor name holding an escape sequence (JSON \u001b), listed by `hdnet info`
header='{"a\u001b[31mred":{"dtype":"F32","shape":[1],"data_offsets":[0,4]}}'
len=$(printf '%s' "$header" | wc -c)
{ printf "\\$(printf %03o "$len")"; printf '\0\0\0\0\0\0\0'; printf '%s' "$header"; printf '\0\0\0\0'; } >esc.safetensors
expect 0 $H info esc.safetensors
grep -q 'a\\x1b\[31mred' out.log || fail "the tensor name is not shown escaped: $(cat out.log)"
if grep -q "$(printf '\033')" out.log; then fail "a raw escape byte of a tensor name reached stdout"; fi

echo "reliability_cli: symlinks, non-finite results, bounded memory, stale temporaries, the run lock, escapes: ok"
