#!/usr/bin/python3
"""head_before_after.py: a relit head before and after a change (docs/usage.md, "The whole head").
Each row: the photo, the relit photo before, after, and the change of log luminance of each
(grey: none; lighter: brighter), cropped to a box about the head at the photo's full resolution.
The relit photos are what `hdnet relight PHOTO --preset K -o OUT.png` writes with each version.
Usage: head_before_after.py OUT.jpg SCALE PHOTO BEFORE.png AFTER.png X0,Y0,X1,Y1 [PHOTO BEFORE AFTER BOX ...]
(SCALE: the rows' zoom, e.g. 1 or 0.5)."""
import sys

import numpy as np
from PIL import Image


def change(photo, relit):
    """log(lum(relit) / lum(photo)) as grey (128: none, 100 levels per unit of log)."""
    lum = lambda x: x @ np.array([0.2126, 0.7152, 0.0722])
    r = np.log((lum(relit) + 2) / (lum(photo) + 2))
    v = np.clip(128 + 100 * r, 0, 255).astype(np.uint8)
    return np.repeat(v[:, :, None], 3, 2)


def row(photo_path, before_path, after_path, box, scale):
    x0, y0, x1, y1 = (int(v) for v in box.split(","))
    load = lambda p: np.asarray(Image.open(p).convert("RGB"), np.float64)
    photo, before, after = load(photo_path), load(before_path), load(after_path)
    cells = [photo, before, after, change(photo, before), change(photo, after)]
    cells = [np.asarray(c[y0:y1, x0:x1], np.uint8) for c in cells]
    gap = np.full((y1 - y0, 6, 3), 255, np.uint8)
    out = Image.fromarray(np.concatenate(sum(([c, gap] for c in cells), [])[:-1], 1))
    return out.resize((int(out.width * scale), int(out.height * scale)), Image.LANCZOS)


def main():
    if len(sys.argv) < 7 or (len(sys.argv) - 3) % 4:
        sys.exit(__doc__)
    scale = float(sys.argv[2])
    rows = [row(*sys.argv[k:k + 4], scale) for k in range(3, len(sys.argv), 4)]
    width = max(r.width for r in rows)
    sheet = Image.new("RGB", (width, sum(r.height + 6 for r in rows) - 6), "white")
    y = 0
    for r in rows:
        sheet.paste(r, (0, y))
        y += r.height + 6
    sheet.save(sys.argv[1], quality=88)


if __name__ == "__main__":
    main()
