#!/usr/bin/python3
"""compare_models.py: the model card's side-by-side sheet of two models on real photos.

One row per photo: the input | relit under preset 1 with model A | with model B | A's albedo |
B's albedo (the full-resolution maps of `hdnet decompose`), each cropped to the face's box (the
photo-frame mask of model B, grown by 12 %) and scaled to a square cell.

    docs/figures/compare_models.py --hdnet build/hdnet A.safetensors B.safetensors OUT.png PHOTO...

Needs Debian's python3 with python3-pil and python3-numpy; runs hdnet itself in a scratch folder.
"""
import argparse
import os
import subprocess
import sys
import tempfile

import numpy as np
from PIL import Image

CELL = 200
GAP = 4


def run(cmd):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        sys.exit("compare_models: %s failed (%d): %s" % (" ".join(cmd), r.returncode, r.stderr.strip()))


def face_box(mask_path, width, height):
    m = np.asarray(Image.open(mask_path).convert("L"), dtype=np.float32) / 255.0
    ys, xs = np.nonzero(m > 0.5)
    if len(xs) == 0:
        sys.exit("compare_models: %s: no face pixels" % mask_path)
    cx, cy = (xs.min() + xs.max()) / 2.0, (ys.min() + ys.max()) / 2.0
    half = 0.5 * 1.12 * max(xs.max() - xs.min(), ys.max() - ys.min())
    x0, y0 = int(max(0, cx - half)), int(max(0, cy - half))
    x1, y1 = int(min(width, cx + half)), int(min(height, cy + half))
    return (x0, y0, x1, y1)


def cell(path, box):
    return Image.open(path).convert("RGB").crop(box).resize((CELL, CELL), Image.LANCZOS)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--hdnet", default="build/hdnet")
    p.add_argument("model_a")
    p.add_argument("model_b")
    p.add_argument("out")
    p.add_argument("photos", nargs="+")
    a = p.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for i, photo in enumerate(a.photos):
            outs = {}
            for tag, model in (("a", a.model_a), ("b", a.model_b)):
                d = os.path.join(tmp, "%d%s" % (i, tag))
                relit = d + ".relit.png"
                run([a.hdnet, "relight", photo, "--preset", "1", "-m", model, "-o", relit])
                run([a.hdnet, "decompose", photo, "-m", model, "-o", d])
                stem = os.path.splitext(os.path.basename(photo))[0]
                outs[tag] = (relit, os.path.join(d, stem + ".photo.albedo.png"),
                             os.path.join(d, stem + ".photo.mask.png"))
            w, h = Image.open(photo).size
            box = face_box(outs["b"][2], w, h)
            rows.append([cell(photo, box), cell(outs["a"][0], box), cell(outs["b"][0], box),
                         cell(outs["a"][1], box), cell(outs["b"][1], box)])
    cols = len(rows[0])
    sheet = Image.new("RGB", (cols * CELL + (cols - 1) * GAP, len(rows) * CELL + (len(rows) - 1) * GAP),
                      (40, 40, 40))
    for r, row in enumerate(rows):
        for c, im in enumerate(row):
            sheet.paste(im, (c * (CELL + GAP), r * (CELL + GAP)))
    sheet.save(a.out)
    print("wrote %s: %d rows" % (a.out, len(rows)))


if __name__ == "__main__":
    main()
