#!/bin/sh
# demo.sh: the one-command demo (`make demo`), with the shipped model:
#  1. the bundled photograph examples/astronaut.png end to end: its face found, unwarped, relit
#     under a preset and under all seven (with a contact sheet), delit, its light estimated, each
#     result warped back and Poisson-blended into the full photo (out/photo/);
#  2. aligned face textures (examples/faces/ if present, else two synthetic faces made here with
#     `hdnet synth`): decomposed, the first relit under the seven presets, the light of the second
#     transferred onto the first, the first delit, and one contact sheet (out/).
# Run from anywhere; uses ./hdnet (or $HDNET) and models/hdnet-synth.safetensors (or the model in
# $HDNET_MODEL).
set -eu
cd "$(dirname "$0")/.."
HDNET=${HDNET:-./hdnet}
photo=examples/astronaut.png
out=out

if [ ! -x "$HDNET" ]; then
    echo "demo: $HDNET is not built; run 'make' first" >&2
    exit 1
fi
if [ -n "${HDNET_MODEL:-}" ]; then
    model=$HDNET_MODEL
else
    model=models/hdnet-synth.safetensors
fi
if [ ! -f "$model" ]; then
    echo "demo: the model $model is missing: the demo needs the shipped model" >&2
    echo "demo: (it ships with the project; or train one with 'hdnet train' and set HDNET_MODEL=path)" >&2
    exit 1
fi
if [ ! -f "$photo" ]; then
    echo "demo: the bundled photograph $photo is missing" >&2
    exit 1
fi
mkdir -p "$out/photo"

# 1. The photograph, end to end.
echo "== relight the face in $photo under preset 0 (light from the right) -> $out/photo/astronaut.relit.png"
"$HDNET" relight "$photo" -m "$model" --preset 0 -o "$out/photo/astronaut.relit.png"
echo "== relight it under the seven presets -> $out/photo/presets/, sheet $out/photo/astronaut.sheet.png"
"$HDNET" relight "$photo" -m "$model" --preset all -o "$out/photo/presets" --sheet "$out/photo/astronaut.sheet.png"
echo "== delight it -> $out/photo/astronaut.delit.png"
"$HDNET" delight "$photo" -m "$model" -o "$out/photo/astronaut.delit.png"
echo "== estimate its light -> $out/photo/astronaut.light.txt, $out/photo/astronaut.light.png"
"$HDNET" estimate-light "$photo" -m "$model" -o "$out/photo/astronaut.light.txt" --preview "$out/photo/astronaut.light.png"

# 2. Aligned face textures.
faces=examples/faces
if [ ! -d "$faces" ]; then
    faces=$out/faces
    echo "== examples/faces/ is not there: two synthetic aligned faces -> $faces/"
    "$HDNET" synth "$faces" --subjects 2 --per-subject 1 --seed 7 >/dev/null
fi
# The face images (not their companions NAME.mask.png etc., nor sheets: those have two dots), sorted.
list=$(find "$faces" -type f \( -name '*.png' -o -name '*.jpg' -o -name '*.jpeg' \) | grep -v '/[^/]*\.[^/]*\.[^/]*$' | sort)
first=$(echo "$list" | sed -n 1p)
second=$(echo "$list" | sed -n 2p)
if [ -z "$first" ] || [ -z "$second" ]; then
    echo "demo: $faces/ holds fewer than two face images" >&2
    exit 1
fi
name=$(basename "$first" | sed 's/\.[^.]*$//')

echo "== decompose $faces/ -> $out/decompose/"
"$HDNET" decompose "$faces" --aligned -m "$model" -o "$out/decompose"
echo "== relight $first under the seven presets -> $out/relight/"
"$HDNET" relight "$first" --aligned -m "$model" --preset all -o "$out/relight" --sheet "$out/sheet.png"
echo "== transfer the light of $second onto $first -> $out/transfer.png"
"$HDNET" transfer "$first" --ref "$second" --aligned -m "$model" -o "$out/transfer.png"
"$HDNET" estimate-light "$second" --aligned -m "$model" -o "$out/ref.light.txt" --preview "$out/ref.light.png"
echo "== delight $first -> $out/delight.png"
"$HDNET" delight "$first" --aligned -m "$model" -o "$out/delight.png"

cat <<DONE

Done. Results in $out/:
  $out/photo/astronaut.relit.png: the photograph, its face relit under preset 0 (same size, background untouched)
  $out/photo/presets/astronaut.preset0.png .. preset6.png: the photograph relit under each preset
  $out/photo/astronaut.sheet.png: contact sheet, photo | delit | relit under presets 0..6
  $out/photo/astronaut.delit.png: the photograph, its face under flat light
  $out/photo/astronaut.light.txt, astronaut.light.png: the light estimated for her face, and on a sphere
  $out/sheet.png: contact sheet, $name | delit | relit under presets 0..6
  $out/decompose/: per face albedo, shading (PNG16 and PFM), normal, light, reconstruction, sheet
  $out/relight/$name.preset0.png .. preset6.png: relit under each preset
  $out/transfer.png: $name under the light of $(basename "$second") ($out/ref.light.txt, $out/ref.light.png)
  $out/delight.png: $name under flat light (its albedo)
DONE
