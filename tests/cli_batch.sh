#!/bin/sh
# cli_batch.sh: many photos through one command (issue 16): relight, delight, transfer,
# estimate-light, decompose and align take files, folders (walked recursively, the layout kept
# below OUT) and @list files; companions (NAME.mask.png) and outputs beside an image are not
# taken as inputs; a faceless or broken photo is reported and skipped, the summary counts it and
# the exit status is 1; the naming rule OUT/REL/NAME.<suffix>; --json of estimate-light, align
# and decompose parsed by python3 -m json.tool. Tiny fresh model; runs in a scratch folder.
set -u
here=$(cd "$(dirname "$0")" && pwd)
HDNET=${HDNET:?HDNET must point at the hdnet tool}
OMP_NUM_THREADS=1
export OMP_NUM_THREADS
TEST=cli_batch
. "$here/cli_common.shlib"
says() { cat out.log err.log | grep -q -- "$1" || { cat out.log err.log >&2; fail "did not say '$1'"; }; }
PY=/usr/bin/python3

expect 0 "$HDNET" init --width 4 --size 32 --seed 1 -o m.safetensors
M="-m m.safetensors"
# photos/a.png, photos/sub/deeper/b.png (faces), photos/sub/gray.png (no face), photos/sub/bad.png
# (not an image), photos/a.relit.png (an output beside its input: not an input), notes.txt
mkdir -p photos/sub/deeper
cp "$here/../examples/astronaut.png" photos/a.png
cp "$here/../examples/astronaut.png" photos/sub/deeper/b.png
cp "$here/../examples/astronaut.png" photos/a.relit.png
# a lit sphere, 48 x 48: no face
expect 0 "$HDNET" light --preset 0 -o l0.txt --preview photos/sub/gray.png --size 48
echo "not an image" >photos/sub/bad.png
echo "not an image" >photos/notes.txt

# relight a folder: the layout kept, the faceless and the broken photo reported and skipped
expect 1 "$HDNET" relight photos $M --preset 2 -o out -j 1
says "relight: 4 photos -> out: 2 done (2 faces), 1 without a face, 1 failed"
says "photos/sub/gray.png: no face found, skipped"
says "photos/sub/bad.png"
exists out/a.relit.png out/sub/deeper/b.relit.png
[ ! -e out/a.relit.relit.png ] || fail "an output beside its input was taken as an input"
[ ! -e out/sub/gray.relit.png ] || fail "an output for the faceless photo"
[ "$(png_size out/a.relit.png)" = "512 512" ] || fail "relit photo is not at the photo's size"
# the same photo alone gives the same picture (one model load serves all)
expect 0 "$HDNET" relight photos/a.png $M --preset 2 -o one.png
cmp -s one.png out/a.relit.png || fail "a photo relit in a batch differs from the photo relit alone"

# two inputs of one name would write the same outputs: refused before any work, both named
mkdir -p twin/x twin/y
cp photos/a.png twin/x/a.png && cp photos/a.png twin/y/a.png
expect_saying 1 "twin/x/a.png and twin/y/a.png would write the same outputs (OUT/a.*)" \
    "$HDNET" relight twin/x/a.png twin/y/a.png $M --preset 2 -o twinout
[ ! -e twinout ] || fail "outputs were written for inputs of one name"
# given as their folder, each keeps its path below it
expect 0 "$HDNET" relight twin $M --preset 2 -o twinout
exists twinout/x/a.relit.png twinout/y/a.relit.png
# a.png and a.jpg side by side in a folder: refused too
cp photos/a.png twin/x/a.jpg
expect_saying 1 "would write the same outputs (OUT/x/a.*)" "$HDNET" delight twin $M -o twindl
[ ! -e twindl ] || fail "outputs were written for a.png and a.jpg of one folder"

# @list: files and folders, comments and blank lines skipped; a faceless photo alone is exit 1
printf '# the photos\nphotos/a.png\n\nphotos/sub/deeper\n' >list.txt
expect 0 "$HDNET" delight @list.txt $M -o dl
says "2 done (2 faces), 0 without a face, 0 failed"
exists dl/a.delit.png dl/b.delit.png
expect_saying 1 "gray.png: no face found" "$HDNET" delight photos/sub/gray.png $M -o x.png
[ ! -e x.png ] || fail "an output for a photo without a face"
expect_saying 1 "missing.txt" "$HDNET" delight @missing.txt $M -o x
expect_saying 1 "empty: no .png/.jpg/.jpeg image" sh -c "mkdir -p empty && $HDNET delight empty $M -o x"
# -o an existing folder with one file: OUT/NAME.<suffix>
mkdir -p into
expect 0 "$HDNET" transfer photos/a.png --ref photos/sub/deeper/b.png $M -o into
exists into/a.transfer.png
expect 0 "$HDNET" relight photos/a.png $M --preset all -o presets
for k in 0 1 2 3 4 5 6; do exists presets/a.preset$k.png; done

# estimate-light: light files by the rule, and --json with every light and the summary
expect 1 "$HDNET" estimate-light photos $M -o lights
exists lights/a.light.txt lights/sub/deeper/b.light.txt
expect 1 "$HDNET" estimate-light photos $M --json
"$PY" -m json.tool out.log >/dev/null || fail "estimate-light --json is not JSON: $(cat out.log)"
"$PY" - <<'PY' || fail "estimate-light --json fields"
import json
d = json.load(open("out.log"))
r, s = d["results"], d["summary"]
assert [x["file"] for x in r] == ["photos/a.png", "photos/sub/deeper/b.png"], r
assert all(len(x["light"]) == 9 and x["faces"] == 1 and x["kind"] == "photo" for x in r), r
assert (s["inputs"], s["done"], s["no_face"], s["failed"], s["faces"]) == (4, 2, 1, 1, 2), s
assert abs(sum(r[0]["light"]) - sum(r[1]["light"])) < 1e-6  # the same photo, the same light
PY
# the printed light is the file's
"$PY" - <<'PY' || fail "the JSON light is not the light file's"
import json
d = json.load(open("out.log"))
f = [float(x) for x in open("lights/a.light.txt").read().split()]
assert max(abs(a - b) for a, b in zip(f, d["results"][0]["light"])) < 1e-6, (f, d["results"][0]["light"])
PY

# decompose and align: the same inputs, the same rule (align: a subject folder per photo)
expect 1 "$HDNET" decompose photos $M -o dec --json
"$PY" -m json.tool out.log >/dev/null || fail "decompose --json is not JSON: $(cat out.log)"
"$PY" - <<'PY' || fail "decompose --json fields"
import json
d = json.load(open("out.log"))
st = {x["file"]: x["status"] for x in d["results"]}
assert st == {"photos/a.png": "done", "photos/sub/deeper/b.png": "done", "photos/sub/gray.png": "no_face",
              "photos/sub/bad.png": "failed"}, st
assert d["summary"]["done"] == 2 and d["summary"]["no_face"] == 1 and d["summary"]["failed"] == 1
PY
exists dec/a.face0.albedo.png dec/a.recon.png dec/sub/deeper/b.face0.light.txt
expect 1 "$HDNET" align photos -o al --size 64 --json
"$PY" - <<'PY' || fail "align --json fields"
import json
d = json.load(open("out.log"))
r = d["results"]
assert [x["file"] for x in r] == ["photos/a.png", "photos/sub/deeper/b.png"], r
f = r[0]["faces"][0]
assert f["index"] == 0 and 0.5 < f["score"] <= 1 and len(f["box"]) == 4 and f["fit_rms"] >= 0, f
assert f["output"] == "al/a/face0", f
PY
exists al/a/face0.png al/sub/deeper/b/face0.warp.txt
echo "cli_batch: all checks passed"
