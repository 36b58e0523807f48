#!/usr/bin/env python3
"""make_seeds.py: builds the fuzzers' seed corpora from the project's own files.

Usage: python3 tests/fuzz/make_seeds.py HDNET OUTDIR
  HDNET   the built hdnet tool (it makes a tiny synthetic set, a model, an alignment)
  OUTDIR  gets one folder per target: png jpeg pfm light safetensors model obj warp tfjs serve lights_csv

Seeds: the synthetic set's PNGs (8 and 16 bit, RGB and gray), PFM shading and light files at
32 x 32; a width-4 model from `hdnet init`; the canonical face mesh (whole and cut); a warp file
from aligning the bundled astronaut photo; a small TF.js graph written here (Conv2D, Relu, Pad,
MaxPool, Reshape) and the shipped face detector's JSON; every file of tests/data/broken of the
target's kind; JPEG seeds are re-encodings of the synthetic images (through hdnet's own files,
so no outside data); for serve, every PNG and JPEG seed as an upload, JSON lights of every form the
page sends and query lights. The corpora are written fresh each time and never committed.
"""
import base64
import glob
import json
import os
import shutil
import struct
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
HDNET, OUT = sys.argv[1], sys.argv[2]
TARGETS = ["png", "jpeg", "pfm", "light", "safetensors", "model", "obj", "warp", "tfjs", "serve", "lights_csv"]


def put(target, name, data):
    with open(os.path.join(OUT, target, name), "wb") as f:
        f.write(data)


def read(path):
    with open(path, "rb") as f:
        return f.read()


def run(*args, cwd):
    subprocess.run([HDNET, *args], cwd=cwd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def tfjs_input(model, shard):
    """The fuzz_tfjs input: 4-byte length, the JSON, the shard."""
    text = json.dumps(model, separators=(",", ":")).encode()
    return struct.pack("<I", len(text)) + text + shard


def small_graph():
    """Placeholder (1,6,6,2) -> Conv2D 3x3x2x3 -> Relu -> Pad -> MaxPool -> Reshape."""
    nodes, weights, shard = [], [], bytearray()

    def node(name, op, inputs=(), **attr):
        nodes.append({"name": name, "op": op, "input": list(inputs), "attr": attr})

    def const(name, shape, values, dtype="float32"):
        node(name, "Const")
        weights.append({"name": name, "shape": shape, "dtype": dtype})
        fmt = "<%d%s" % (len(values), "f" if dtype == "float32" else "i")
        shard.extend(struct.pack(fmt, *values))

    def s(text):
        return {"s": base64.b64encode(text.encode()).decode()}

    def ints(v):
        return {"list": {"i": [str(x) for x in v]}}

    node("x", "Placeholder", shape={"shape": {"dim": [{"size": d} for d in ("-1", "6", "6", "2")]}})
    const("f", [3, 3, 2, 3], [((i * 7) % 11 - 5) / 8.0 for i in range(54)])
    const("pads", [4, 2], [0, 0, 1, 1, 2, 0, 0, 1], "int32")
    const("shape", [2], [-1, 64], "int32")
    node("c", "Conv2D", ["x", "f"], strides=ints([1, 1, 1, 1]), dilations=ints([1, 1, 1, 1]), padding=s("SAME"),
         data_format=s("NHWC"))
    node("r", "Relu", ["c"])
    node("p", "Pad", ["r", "pads"])
    node("m", "MaxPool", ["p"], strides=ints([1, 2, 2, 1]), ksize=ints([1, 2, 2, 1]), padding=s("SAME"),
         data_format=s("NHWC"))
    node("y", "Reshape", ["m", "shape"])
    model = {"format": "graph-model", "modelTopology": {"node": nodes},
             "weightsManifest": [{"paths": ["g.bin"], "weights": weights}]}
    return model, bytes(shard)


def serve_seeds():
    """fuzz_serve: byte 0 picks the part (0 upload, 1 JSON light, 2 query light)."""
    for t in ("png", "jpeg"):  # the broken files (its regression inputs among them) and good ones
        for name in sorted(os.listdir(os.path.join(OUT, t))):
            put("serve", "upload_" + name, b"\x00" + read(os.path.join(OUT, t, name)))
    bodies = ['{"light": [0.8, -0.2, 0.3, 0.1, 0, 0, 0, 0, 0]}', '{"preset": 3}', '{"preset": 3, "brightness": "free"}',
              '{"azimuth": 30, "elevation": -10}', '{"azimuth": 30, "elevation": 10, "intensity": 0.9, "ambient": 0.4}',
              '{"light": [1e38, 0, 0, 0, 0, 0, 0, 0, 0]}', '{"azimuth": 1e300, "elevation": 0}', '[1, 2]']
    for i, body in enumerate(bodies):
        put("serve", "json_%d" % i, b"\x01" + body.encode())
    # present bits: preset, azimuth, elevation, intensity, ambient
    queries = [(0x01, "4"), (0x06, "30\n-15"), (0x1e, "30\n-15\n0.8\n0.3"), (0x06, "nan\n0"), (0x07, "1\n2\n3")]
    for i, (bits, text) in enumerate(queries):
        put("serve", "query_%d" % i, b"\x02" + bytes([bits]) + text.encode())


def main():
    if os.path.isdir(OUT):
        shutil.rmtree(OUT)
    for t in TARGETS:
        os.makedirs(os.path.join(OUT, t))
    broken = os.path.join(ROOT, "tests", "data", "broken")
    kinds = {"png_": "png", "jpeg_": "jpeg", "pfm_": "pfm", "light_": "light", "st_": "safetensors",
             "obj_": "obj", "warp_": "warp", "tfjs_": "tfjs"}
    for path in sorted(glob.glob(os.path.join(broken, "*"))):
        name = os.path.basename(path)
        for prefix, target in kinds.items():
            if name.startswith(prefix) and os.path.getsize(path) <= 65536:
                put(target, name, read(path))
                if target == "safetensors":
                    put("model", name, read(path))
    with tempfile.TemporaryDirectory() as tmp:
        run("synth", "data", "--subjects", "1", "--per-subject", "2", "--size", "32", "--seed", "7", "--threads", "1",
            cwd=tmp)
        subject = os.path.join(tmp, "data", "subject_0000")
        for path in sorted(glob.glob(os.path.join(subject, "*"))):
            name = os.path.basename(path)
            if name.endswith(".png"):
                put("png", name, read(path))
            elif name.endswith(".pfm"):
                put("pfm", name, read(path))
            elif name.endswith(".light.txt"):
                put("light", name, read(path))
        run("init", "--width", "4", "--size", "32", "--seed", "1", "-o", "m.safetensors", cwd=tmp)
        put("safetensors", "init.safetensors", read(os.path.join(tmp, "m.safetensors")))
        put("model", "init.safetensors", read(os.path.join(tmp, "m.safetensors")))
        # JPEG: the baseline files make_broken.py builds from first principles (it writes its
        # broken corpus into a scratch folder here; its builder is then reused)
        saved = sys.argv
        sys.argv = ["make_broken.py", os.path.join(tmp, "broken")]
        import importlib.util
        spec = importlib.util.spec_from_file_location("make_broken", os.path.join(ROOT, "tests", "data", "make_broken.py"))
        broken_mod = importlib.util.module_from_spec(spec)
        with open(os.devnull, "w") as quiet:
            stdout, sys.stdout = sys.stdout, quiet
            try:
                spec.loader.exec_module(broken_mod)
            finally:
                sys.stdout = stdout
        sys.argv = saved
        put("jpeg", "gray128.jpg", broken_mod.good_jpeg)
        put("jpeg", "rgb16.jpg", broken_mod.jpeg(16, 16, ncomp=3))
        try:
            run("align", os.path.join(ROOT, "examples", "astronaut.png"), "-o", "aligned", "--size", "64", cwd=tmp)
            for path in sorted(glob.glob(os.path.join(tmp, "aligned", "*", "*.warp.txt"))):
                put("warp", os.path.basename(path), read(path))
        except subprocess.CalledProcessError:
            pass
    obj = read(os.path.join(ROOT, "models", "canonical_face_model.obj"))
    put("obj", "canonical.obj", obj)
    put("obj", "canonical_cut.obj", obj[:3000])
    model, shard = small_graph()
    put("tfjs", "small_graph", tfjs_input(model, shard))
    face = json.loads(read(os.path.join(ROOT, "models", "face-models", "blazeface-front.json")))
    for group in face.get("weightsManifest", []):
        group["paths"] = ["g.bin"]
    put("tfjs", "blazeface_no_shard", tfjs_input(face, b""))
    serve_seeds()
    header = b"file,subject,azimuth_deg,elevation_deg\n"
    put("lights_csv", "yale.csv", header + b"yaleB01/yaleB01_P00A+000E+00.png,yaleB01,0,0\r\n"
        b"yaleB01/yaleB01_P00A-035E+40.png,yaleB01,-35,40\n\nb/b.png, b ,+130,-90\n")
    put("lights_csv", "bad.csv", header + b"../x.png,a,1e999,0\nx,,0\n")
    counts = {t: len(os.listdir(os.path.join(OUT, t))) for t in TARGETS}
    print("seeds: " + ", ".join("%s %d" % (t, n) for t, n in counts.items()))


main()
