#!/usr/bin/python3
"""eyes_disc.py: the eyes in two versions of a relight sheet (docs/usage.md, "no cap at the eyes").
Each sheet is what `hdnet eval DIR --photos --sheets` writes (top row: the paper's rule, bottom row:
the ratio rule; columns: the photo, presets 0..6, the delit face); this takes the bottom row's
photo, preset 0 and preset 2 (light from either side), the band of the eyes, from the sheet before
and the sheet after a change, one above the other, for each pair of sheets given.
Usage: eyes_disc.py OUT.jpg BEFORE1.png AFTER1.png [BEFORE2.png AFTER2.png ...]"""
import sys
from hairline_band import stack

if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    stack(sys.argv[1], sys.argv[2:], (0, 1, 3), 0.2, 0.5, __doc__)
