#!/usr/bin/python3
"""hairline_band.py: the top of the face in two versions of a relight sheet (docs/usage.md, "up to
the hairline"). Each sheet is what `hdnet eval DIR --photos --sheets` writes (top row: the paper's
rule, bottom row: the ratio rule; columns: the photo, presets 0..6, the delit face); this takes the
bottom row's photo, preset 0, preset 5 and preset 6, the forehead only, from the sheet before and
the sheet after a change, one above the other, for each pair of sheets given.
Usage: hairline_band.py OUT.jpg BEFORE1.png AFTER1.png [BEFORE2.png AFTER2.png ...]"""
import sys
from PIL import Image

COLUMNS = (0, 1, 6, 7)  # the photo, presets 0, 5 and 6
CELLS = 9


def forehead_row(path):
    sheet = Image.open(path).convert("RGB")
    cell_w, top = sheet.size[0] / CELLS, sheet.size[1] // 2
    width, height = int(cell_w) - 10, int(cell_w * 0.5)
    row = Image.new("RGB", (width * len(COLUMNS), height))
    for j, k in enumerate(COLUMNS):
        x0 = int(k * cell_w)
        row.paste(sheet.crop((x0, top, x0 + width, top + height)), (j * width, 0))
    return row


def main(argv):
    if len(argv) < 3 or len(argv) % 2 == 0:
        sys.exit(__doc__)
    rows = [forehead_row(p) for p in argv[1:]]
    width = max(r.size[0] for r in rows)
    out = Image.new("RGB", (width, sum(r.size[1] for r in rows)), (255, 255, 255))
    y = 0
    for r in rows:
        out.paste(r, (0, y))
        y += r.size[1]
    out.save(argv[0])


if __name__ == "__main__":
    main(sys.argv[1:])
