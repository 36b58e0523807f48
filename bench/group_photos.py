#!/usr/bin/python3
"""group_photos.py: face detection on group photos composed from real portraits (docs/face_detect.md).

We have no real group photos with ground truth, so this builds them from the Face Research Lab
London Set (DeBruine & Jones 2017, CC BY 4.0): each portrait's head (its pupils from NAME.tem,
points 0 and 1) is cut out with a feathered oval, scaled to a face width of 40-200 px (face width
= 2.1 x the distance between the pupils, about the detector's box) and pasted at a free place of a
cluttered canvas (smooth colour noise, flat boxes, grain) of up to 4000 px, saved as JPEG (quality
90). `hdnet detect --json --no-landmarks` runs on each canvas at the default settings; a true face
is found when a detection's eye keypoints lie within half the pupil distance of its pupils (each
detection counts for one face); a detection that matches no face is a false face, a second one on
the same face a duplicate. Prints the rate per canvas and per face width, and the seconds per
megapixel. --vary makes it harder: each head rolled by up to 20 degrees, under a gain of
0.45-1.25 with a colour cast, blurred by up to 1.2 px. Deterministic for a seed.

usage: bench/group_photos.py HDNET FACES_DIR [--vary] [--seed S] [--keep DIR] [--min-score S] [--threads N]
       (FACES_DIR: the London set, ID/neutral.jpg + ID/neutral.tem; needs python3-numpy, python3-pil)
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
from PIL import Image, ImageFilter

# (width, height, faces): the case first (two 95 px faces side by side in 1024 x 512)
CANVASES = [(1024, 512, 2), (1600, 1200, 12), (2400, 1600, 20), (3000, 2000, 24), (4000, 3000, 30),
            (4000, 2250, 20)]
FACE_MIN, FACE_MAX = 40.0, 200.0
BINS = [(40, 60), (60, 100), (100, 150), (150, 201)]


def portraits(faces_dir):
    out = []
    for person in sorted(os.listdir(faces_dir)):
        jpg, tem = (os.path.join(faces_dir, person, "neutral" + e) for e in (".jpg", ".tem"))
        if not (os.path.isfile(jpg) and os.path.isfile(tem)):
            continue
        with open(tem) as f:
            f.readline()
            pts = [tuple(map(float, f.readline().split()[:2])) for _ in range(2)]
        out.append((person, jpg, pts))
    return out


def background(rng, w, h):
    """Smooth colour noise, flat boxes and grain: clutter without faces."""
    small = rng.uniform(40, 220, size=(max(2, h // 64), max(2, w // 64), 3)).astype(np.uint8)
    bg = Image.fromarray(small).resize((w, h), Image.BICUBIC)
    a = np.asarray(bg).astype(np.float32)
    for _ in range(int(w * h / 90000)):
        bw, bh = rng.integers(20, 300, size=2)
        x, y = rng.integers(0, w - 1), rng.integers(0, h - 1)
        a[y:y + bh, x:x + bw] = rng.uniform(20, 235, size=3)
    a += rng.normal(0, 6, size=a.shape)
    return np.clip(a, 0, 255)


def oval_mask(w, h, feather):
    y, x = np.mgrid[0:h, 0:w].astype(np.float32)
    r = np.sqrt(((x + 0.5 - w / 2) / (w / 2)) ** 2 + ((y + 0.5 - h / 2) / (h / 2)) ** 2)
    return np.clip((1.0 - r) / feather, 0.0, 1.0)


def compose(rng, people, w, h, n, vary):
    """A canvas with n faces; returns the RGB array and the truth [(face width, pupil a, pupil b,
    person)]. vary: each head also rolled by up to 20 degrees, under a gain of 0.45-1.25 with a
    colour cast, and blurred by up to 1.2 px."""
    canvas = background(rng, w, h)
    taken, truth = [], []
    order = rng.permutation(len(people))
    k = 0
    for tries in range(n * 200):
        if len(truth) == n:
            break
        fw = float(math.exp(rng.uniform(math.log(FACE_MIN), math.log(FACE_MAX))))
        person, jpg, (p0, p1) = people[order[k % len(order)]]
        ipd = math.dist(p0, p1)
        s = fw / (2.1 * ipd)
        # the head: 3.4 x 4.2 pupil distances, centred half a pupil distance below the eyes
        cw, ch = 3.4 * ipd, 4.2 * ipd
        cx, cy = (p0[0] + p1[0]) / 2, (p0[1] + p1[1]) / 2 + 0.5 * ipd
        hw, hh = int(round(cw * s)), int(round(ch * s))
        box = (cx - cw / 2, cy - ch / 2, cx + cw / 2, cy + ch / 2)
        img = Image.open(jpg).convert("RGB")
        head = img.resize((hw, hh), Image.LANCZOS, box=box)
        alpha = Image.fromarray((oval_mask(hw, hh, 0.15) * 255).astype(np.uint8))
        angle = float(rng.uniform(-20, 20)) if vary else 0.0
        if vary:
            head = head.filter(ImageFilter.GaussianBlur(float(rng.uniform(0, 1.2))))
            head = head.rotate(angle, Image.BICUBIC, expand=True)
            alpha = alpha.rotate(angle, Image.BICUBIC, expand=True)
        pw, ph = head.size
        if pw >= w or ph >= h:
            continue
        x0, y0 = int(rng.integers(0, w - pw)), int(rng.integers(0, h - ph))
        if any(x0 < bx + bw and bx < x0 + pw and y0 < by + bh and by < y0 + ph for bx, by, bw, bh in taken):
            continue
        rgb = np.asarray(head).astype(np.float32)
        if vary:
            rgb = rgb * rng.uniform(0.45, 1.25) * rng.uniform(0.8, 1.2, size=3)
        m = (np.asarray(alpha).astype(np.float32) / 255)[..., None]
        region = canvas[y0:y0 + ph, x0:x0 + pw]
        canvas[y0:y0 + ph, x0:x0 + pw] = m * rgb + (1 - m) * region
        th = math.radians(angle)

        def to_canvas(p):  # portrait pixels -> the head's pixels -> rolled about its centre -> canvas
            dx, dy = (p[0] - box[0]) * s - hw / 2, (p[1] - box[1]) * s - hh / 2
            return (x0 + pw / 2 + dx * math.cos(th) + dy * math.sin(th),
                    y0 + ph / 2 - dx * math.sin(th) + dy * math.cos(th))
        taken.append((x0, y0, pw, ph))
        truth.append((fw, to_canvas(p0), to_canvas(p1), person))
        k += 1
    return canvas.astype(np.uint8), truth


def match(truth, faces):
    """found[i]: detection index for true face i or -1; the false and duplicate detection counts."""
    used = [False] * len(faces)
    found = []
    for fw, a, b, _ in truth:
        mid, ipd = ((a[0] + b[0]) / 2, (a[1] + b[1]) / 2), math.dist(a, b)
        best, best_d = -1, 0.5 * ipd
        for j, f in enumerate(faces):
            kp = f["keypoints"]
            e0, e1 = kp["right_eye"], kp["left_eye"]
            d = math.dist(mid, ((e0[0] + e1[0]) / 2, (e0[1] + e1[1]) / 2))
            if not used[j] and d <= best_d:
                best, best_d = j, d
        if best >= 0:
            used[best] = True
        found.append(best)
    dup = false = 0
    for j, f in enumerate(faces):
        if used[j]:
            continue
        x0, y0, x1, y1 = f["box"]
        on_face = any(x0 <= (a[0] + b[0]) / 2 <= x1 and y0 <= (a[1] + b[1]) / 2 <= y1 for _, a, b, _ in truth)
        dup += on_face
        false += not on_face
    return found, false, dup


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("hdnet")
    ap.add_argument("faces_dir")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--keep", help="keep the canvases (and an annotated one) in this folder")
    ap.add_argument("--min-score", help="passed to hdnet detect (default: its default)")
    ap.add_argument("--threads", default="2")
    ap.add_argument("--vary", action="store_true",
                    help="roll each head by up to 20 degrees, change its exposure and colour, blur it")
    args = ap.parse_args()
    people = portraits(args.faces_dir)
    if len(people) < 10:
        sys.exit(f"group_photos.py: {args.faces_dir}: {len(people)} portraits with a .tem, need 10 or more")
    rng = np.random.default_rng(args.seed)
    work = args.keep or tempfile.mkdtemp(prefix="hdnet-groups.")
    os.makedirs(work, exist_ok=True)
    total = found_n = false_n = dup_n = 0
    per_bin = {b: [0, 0] for b in BINS}
    mpix = cpu = wall = 0.0
    missed = []
    print("| canvas | faces | found | false | duplicate | s | s/MP |")
    print("|---|---|---|---|---|---|---|")
    for i, (w, h, n) in enumerate(CANVASES):
        if i == 0:  # the case: two 95 px faces side by side
            save = (FACE_MIN, FACE_MAX)
            globals()["FACE_MIN"] = globals()["FACE_MAX"] = 95.0
        canvas, truth = compose(rng, people, w, h, n, args.vary)
        if i == 0:
            globals()["FACE_MIN"], globals()["FACE_MAX"] = save
        path = os.path.join(work, f"group{i}_{w}x{h}.jpg")
        Image.fromarray(canvas).save(path, quality=90)
        cmd = [args.hdnet, "detect", path, "--json", "--no-landmarks", "-j", args.threads]
        if args.min_score:
            cmd += ["--min-score", args.min_score]
        t0, c0 = time.time(), os.times()
        run = subprocess.run(cmd, capture_output=True, text=True)
        t1, c1 = time.time(), os.times()
        if run.returncode != 0:
            sys.exit(f"group_photos.py: {' '.join(cmd)}: exit {run.returncode}: {run.stderr.strip()}")
        faces = json.loads(run.stdout)["faces"]
        found, false, dup = match(truth, faces)
        ok = sum(f >= 0 for f in found)
        for (fw, a, b, person), f in zip(truth, found):
            for b in BINS:
                if b[0] <= fw < b[1]:
                    per_bin[b][0] += 1
                    per_bin[b][1] += f >= 0
            if f < 0:
                missed.append(f"{os.path.basename(path)}: {person} at {fw:.0f} px, eyes at "
                              f"({(a[0] + b[0]) / 2:.0f}, {(a[1] + b[1]) / 2:.0f})")
        total, found_n, false_n, dup_n = total + len(truth), found_n + ok, false_n + false, dup_n + dup
        mp = w * h / 1e6
        c = (c1.children_user - c0.children_user) + (c1.children_system - c0.children_system)
        mpix, cpu, wall = mpix + mp, cpu + c, wall + (t1 - t0)
        print(f"| {w} x {h} | {len(truth)} | {ok} | {false} | {dup} | {t1 - t0:.1f} | {c / mp:.2f} (CPU) |")
    print()
    print("| face width (px) | faces | found |")
    print("|---|---|---|")
    for b in BINS:
        t, f = per_bin[b]
        print(f"| {b[0]}-{b[1] - 1} | {t} | {f} ({100.0 * f / max(t, 1):.1f} %) |")
    print()
    print(f"all: {found_n} of {total} faces found ({100.0 * found_n / total:.1f} %), {false_n} false, "
          f"{dup_n} duplicate; {cpu / mpix:.2f} s of CPU per megapixel ({wall:.0f} s wall for {mpix:.1f} MP, "
          f"load average {os.getloadavg()[0]:.1f})")
    for m in missed:
        print("missed:", m)
    if args.keep:
        print(f"canvases in {work}")


if __name__ == "__main__":
    main()
