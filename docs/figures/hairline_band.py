#!/usr/bin/python3
"""hairline_band.py: the top of the face in two versions of a relight sheet (docs/usage.md, "up to
the hairline"). Each sheet is what `hdnet eval DIR --photos --sheets` writes (top row: the paper's
rule, bottom row: the ratio rule; columns: the photo, presets 0..6, the delit face); this takes the
bottom row's photo, preset 0, preset 5 and preset 6, the forehead only, from the sheet before and
the sheet after a change, one above the other, for each pair of sheets given.
Usage: hairline_band.py OUT.jpg BEFORE1.png AFTER1.png [BEFORE2.png AFTER2.png ...]"""
import sys
from PIL import Image

CELLS = 9


def sheet_band(path, columns, top, bottom):
    """The bottom row's cells `columns` of the sheet at path, from `top` to `bottom` below the row's
    top (shares of a cell's width), side by side."""
    sheet = Image.open(path).convert("RGB")
    cell_w, row_top = sheet.size[0] / CELLS, sheet.size[1] // 2
    width = int(cell_w) - 10
    y0, y1 = row_top + int(top * cell_w), row_top + int(bottom * cell_w)
    row = Image.new("RGB", (width * len(columns), y1 - y0))
    for j, k in enumerate(columns):
        x0 = int(k * cell_w)
        row.paste(sheet.crop((x0, y0, x0 + width, y1)), (j * width, 0))
    return row


def stack(out_path, paths, columns, top, bottom, doc):
    """The bands of every sheet in paths (before, after, before, after ...), one above the other."""
    if len(paths) < 2 or len(paths) % 2:
        sys.exit(doc)
    rows = [sheet_band(p, columns, top, bottom) for p in paths]
    out = Image.new("RGB", (max(r.size[0] for r in rows), sum(r.size[1] for r in rows)), (255, 255, 255))
    y = 0
    for r in rows:
        out.paste(r, (0, y))
        y += r.size[1]
    out.save(out_path, quality=90)


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    stack(sys.argv[1], sys.argv[2:], (0, 1, 6, 7), 0.0, 0.5, __doc__)  # the photo, presets 0, 5, 6; the forehead
