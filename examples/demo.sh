#!/bin/sh
# demo.sh: the one-command demo (`make demo`): with the shipped model, decomposes the bundled
# example faces (examples/faces/, aligned textures made by `hdnet synth`), relights the first one
# under the seven presets, transfers the light of the second onto the first, delights the first,
# and writes everything and one contact sheet into out/. Run from anywhere; uses ./hdnet (or
# $HDNET) and models/hdnet-synth.safetensors (or the model in $HDNET_MODEL).
set -eu
cd "$(dirname "$0")/.."
HDNET=${HDNET:-./hdnet}
faces=examples/faces
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
if [ ! -d "$faces" ]; then
    echo "demo: the example faces ($faces/) are missing" >&2
    exit 1
fi
# The face images (not their companions NAME.mask.png etc.: those have two dots), sorted.
list=$(find "$faces" -type f \( -name '*.png' -o -name '*.jpg' -o -name '*.jpeg' \) | grep -v '/[^/]*\.[^/]*\.[^/]*$' | sort)
first=$(echo "$list" | sed -n 1p)
second=$(echo "$list" | sed -n 2p)
if [ -z "$first" ] || [ -z "$second" ]; then
    echo "demo: $faces/ holds fewer than two face images" >&2
    exit 1
fi
name=$(basename "$first" | sed 's/\.[^.]*$//')
mkdir -p "$out"

echo "== decompose $faces/ -> $out/decompose/"
"$HDNET" decompose "$faces" -m "$model" -o "$out/decompose"
echo "== relight $first under the seven presets -> $out/relight/"
"$HDNET" relight "$first" -m "$model" --preset all -o "$out/relight" --sheet "$out/sheet.png"
echo "== transfer the light of $second onto $first -> $out/transfer.png"
"$HDNET" transfer "$first" --ref "$second" -m "$model" -o "$out/transfer.png"
"$HDNET" estimate-light "$second" -m "$model" -o "$out/ref.light.txt" --preview "$out/ref.light.png"
echo "== delight $first -> $out/delight.png"
"$HDNET" delight "$first" -m "$model" -o "$out/delight.png"

cat <<DONE

Done. Results in $out/:
  $out/sheet.png: contact sheet, $name | delit | relit under presets 0..6
  $out/decompose/: per face albedo, shading (PNG16 and PFM), normal, light, reconstruction, sheet
  $out/relight/$name.preset0.png .. preset6.png: relit under each preset
  $out/transfer.png: $name under the light of $(basename "$second") ($out/ref.light.txt, $out/ref.light.png)
  $out/delight.png: $name under flat light (its albedo)
DONE
