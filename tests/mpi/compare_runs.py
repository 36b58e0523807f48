#!/usr/bin/python3
"""compare_runs.py: are two training runs the same up to float summation order?

usage: compare_runs.py RUN_A RUN_B [--tol 1e-5]
Compares RUN/checkpoint.safetensors (every tensor: parameters, discriminator, Adam moments) and
RUN/loss.csv (every loss of every iteration). A tensor's difference is max|a - b| / max|a| (the
largest element difference relative to the tensor's scale, so that near-zero elements do not
blow it up); a loss's is |a - b| / |a|. Prints the worst of each and exits 1 if one exceeds tol,
or if the files differ in their tensors, shapes or rows."""
import json
import struct
import sys

import numpy as np


def read_safetensors(path):
    with open(path, "rb") as f:
        raw = f.read()
    (n,) = struct.unpack("<Q", raw[:8])
    header = json.loads(raw[8:8 + n])
    data = raw[8 + n:]
    out = {}
    for name, t in header.items():
        if name == "__metadata__":
            continue
        if t["dtype"] != "F32":
            sys.exit(f"{path}: tensor {name} is {t['dtype']}, not F32")
        a, b = t["data_offsets"]
        out[name] = np.frombuffer(data[a:b], dtype="<f4").reshape(t["shape"])
    return out, header.get("__metadata__", {})


def read_csv(path):
    with open(path) as f:
        head = f.readline().strip().split(",")
        rows = [[float(x) for x in line.split(",")] for line in f if line.strip()]
    # the last column is the wall time of the row: not compared
    return head[:-1], np.array([r[:-1] for r in rows])


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    tol = 1e-5
    if "--tol" in sys.argv:
        tol = float(sys.argv[sys.argv.index("--tol") + 1])
        args.remove(sys.argv[sys.argv.index("--tol") + 1])
    if len(args) != 2:
        sys.exit(__doc__)
    a_dir, b_dir = args
    ta, ma = read_safetensors(f"{a_dir}/checkpoint.safetensors")
    tb, mb = read_safetensors(f"{b_dir}/checkpoint.safetensors")
    bad = 0
    if sorted(ta) != sorted(tb):
        print(f"tensors differ: {sorted(set(ta) ^ set(tb))[:5]}")
        return 1
    if ma.get("iteration") != mb.get("iteration"):
        print(f"iterations differ: {ma.get('iteration')} vs {mb.get('iteration')}")
        return 1
    worst, worst_name = 0.0, ""
    for name in ta:
        x, y = ta[name].astype(np.float64), tb[name].astype(np.float64)
        if x.shape != y.shape:
            print(f"{name}: shapes {x.shape} vs {y.shape}")
            return 1
        scale = np.max(np.abs(x)) if x.size else 0.0
        d = np.max(np.abs(x - y)) / scale if scale > 0 else np.max(np.abs(x - y), initial=0.0)
        if d > worst:
            worst, worst_name = d, name
    print(f"checkpoint at iteration {ma.get('iteration')}: {len(ta)} tensors, worst relative difference {worst:.3g} ({worst_name})")
    bad |= worst > tol
    ha, la = read_csv(f"{a_dir}/loss.csv")
    hb, lb = read_csv(f"{b_dir}/loss.csv")
    if ha != hb or la.shape != lb.shape:
        print(f"loss.csv differ in columns or rows: {la.shape} vs {lb.shape}")
        return 1
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.where(np.abs(la) > 0, np.abs(la - lb) / np.abs(la), np.abs(la - lb))
    i, k = np.unravel_index(np.argmax(rel), rel.shape)
    print(f"loss.csv: {la.shape[0]} rows, worst relative difference {rel[i, k]:.3g} ({ha[k]} at row {i + 1})")
    bad |= rel[i, k] > tol
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
