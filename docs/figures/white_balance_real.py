#!/usr/bin/python3
"""white_balance_real.py: what --white-balance eyes does on real photos (docs/usage.md, "White
balance"). For each photo: its albedo, and the albedo of a copy under a warm and a cool cast, with
the balance off and on; prints the mean |albedo(cast) - albedo(photo, off)| over the face's mask,
and how much the balance moves the albedo of the photo itself. --sheet: the first three photos, one
row each: photo | albedo | warm copy | its albedo, off | on | cool copy | its albedo, off | on.
Usage: white_balance_real.py [--sheet OUT.png] PHOTO ...  (HDNET_LIBRARY / PYTHONPATH as for hdnet)"""
import sys
import numpy as np
import hdnet

CASTS = {"warm": (1.2, 1.0, 0.8), "cool": (0.85, 1.0, 1.2)}


def main(argv):
    sheet = None
    if argv[:1] == ["--sheet"]:
        sheet, argv = argv[1], argv[2:]
    from PIL import Image
    off, on = hdnet.Model(), hdnet.Model(white_balance=True)
    rows, tiles = [], []
    for path in argv:
        photo = np.asarray(Image.open(path).convert("RGB"), np.float32) / 255
        a0 = off.decompose(photo)[0]
        mask = a0.sum(axis=2) > 0.02
        row = [np.abs(on.decompose(photo)[0] - a0)[mask].mean()]
        tile = [photo, a0]
        for name, g in CASTS.items():
            cast = np.clip(photo * np.array(g, np.float32), 0, 1)
            a_off, a_on = off.decompose(cast)[0], on.decompose(cast)[0]
            row += [np.abs(a_off - a0)[mask].mean(), np.abs(a_on - a0)[mask].mean()]
            tile += [cast, a_off, a_on]
        rows.append(row)
        tiles.append(tile)
        print("%-40s photo on-off %.4f | warm off %.4f on %.4f | cool off %.4f on %.4f" % ((path,) + tuple(row)))
    r = np.median(np.array(rows), axis=0)
    print("median over %d photos: photo on-off %.4f | warm off %.4f on %.4f | cool off %.4f on %.4f" % ((len(rows),) + tuple(r)))
    if sheet and tiles:
        s = off.size
        def pic(x):  # a photo is shown cropped to its middle two thirds, a texture whole
            if x.shape[0] > 2 * s:
                c = x.shape[0] // 6
                x = x[c:-c, c:-c]
            return Image.fromarray((np.clip(x, 0, 1) * 255 + 0.5).astype(np.uint8)).resize((s, s))
        out = Image.new("RGB", (s * 8, s * min(len(tiles), 3)))
        for j, t in enumerate(tiles[:3]):
            for i, x in enumerate(t):
                out.paste(pic(x), (s * i, s * j))
        out.save(sheet)


if __name__ == "__main__":
    main(sys.argv[1:])
