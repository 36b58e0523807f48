#!/bin/sh
# cli_json.sh: --json of detect and info (issue 16), parsed by python3 -m json.tool and checked
# field by field against the text output and the files (estimate-light, align and decompose are
# tests/cli_batch.sh's). Runs in a scratch folder.
set -u
here=$(cd "$(dirname "$0")" && pwd)
HDNET=${HDNET:?HDNET must point at the hdnet tool}
OMP_NUM_THREADS=1
export OMP_NUM_THREADS
TEST=cli_json
. "$here/cli_common.shlib"
PY=/usr/bin/python3
photo="$here/../examples/astronaut.png"

# detect: the faces, their boxes and keypoints, the landmarks file's points
expect 0 "$HDNET" detect "$photo" --landmarks lm.txt -o drawn.png --json
"$PY" -m json.tool out.log >/dev/null || fail "detect --json is not JSON: $(head -c 300 out.log)"
cp out.log detect.json
expect 0 "$HDNET" detect "$photo"
cp out.log detect.txt
"$PY" - <<'PY' || fail "detect --json fields"
import json, re
d = json.load(open("detect.json"))
assert (d["width"], d["height"], d["min_score"]) == (512, 512, 0.75), d
assert d["output"] == "drawn.png" and d["landmarks_file"] == "lm.txt"
f = d["faces"]
assert len(f) == 1 and f[0]["index"] == 0
# the text output's score and box, to its printed precision
m = re.search(r"face 0: score ([\d.]+) box \(([\d.]+), ([\d.]+)\)-\(([\d.]+), ([\d.]+)\)", open("detect.txt").read())
assert abs(f[0]["score"] - float(m.group(1))) < 1e-3, (f[0]["score"], m.group(1))
assert all(abs(a - float(b)) < 0.06 for a, b in zip(f[0]["box"], m.groups()[1:])), (f[0]["box"], m.groups())
kp = f[0]["keypoints"]
assert sorted(kp) == sorted(["right_eye", "left_eye", "nose_tip", "mouth", "right_ear", "left_ear"]), kp
x0, y0, x1, y1 = f[0]["box"]
assert all(x0 <= p[0] <= x1 and y0 <= p[1] <= y1 for k, p in kp.items() if "ear" not in k), kp
# the landmarks: 468 points, the same as the file's
lm = f[0]["landmarks"]
rows = [list(map(float, l.split())) for l in open("lm.txt") if not l.startswith("#")]
assert len(lm) == 468 == len(rows)
assert max(abs(a - b) for p, q in zip(lm, rows) for a, b in zip(p, q)) < 2e-3
assert 0.5 < f[0]["presence"] <= 1
PY
# no face: an empty list, exit 0; an unreadable photo: exit 1, nothing on stdout
expect 0 "$HDNET" light --preset 0 -o l.txt --preview sphere.png --size 64
expect 0 "$HDNET" detect sphere.png --json
"$PY" -c 'import json,sys; d=json.load(open("out.log")); sys.exit(d["faces"] != [])' || fail "detect --json of a faceless picture"
echo "not an image" >bad.png
expect 1 "$HDNET" detect bad.png --json
[ ! -s out.log ] || fail "detect --json of a broken file printed: $(cat out.log)"

# info: an image, a light file, a checkpoint and a broken file in one document (exit 1)
expect 0 "$HDNET" init --width 4 --size 32 --seed 1 -o m.safetensors
expect 1 "$HDNET" info sphere.png l.txt m.safetensors bad.png --json
"$PY" -m json.tool out.log >/dev/null || fail "info --json is not JSON: $(head -c 300 out.log)"
grep -q "bad.png" err.log || fail "info did not report bad.png on stderr"
"$PY" - <<'PY' || fail "info --json fields"
import json
d = json.load(open("out.log"))
img, light, ckpt, bad = d["files"]
assert (img["kind"], img["format"], img["width"], img["height"], img["channels"], img["bits"]) == ("image", "PNG", 64, 64, 3, 8), img
assert [c["name"] for c in img["channel_stats"]] == ["red", "green", "blue"]
assert all(0 <= c["min"] <= c["mean"] <= c["max"] <= 1 for c in img["channel_stats"])
f = [float(x) for x in open("l.txt").read().split()]
assert light["kind"] == "light" and max(abs(a - b) for a, b in zip(f, light["light"])) < 1e-6, light
assert set(light["shading"]) == {"viewer", "right", "left", "up", "down"}
assert ckpt["kind"] == "safetensors" and ckpt["parameters"] == sum(
    __import__("math").prod(t["shape"]) for t in ckpt["tensors"]), ckpt["parameters"]
assert "error" in bad and "kind" not in bad, bad
assert d["failed"] == 1
PY
echo "cli_json: all checks passed"
