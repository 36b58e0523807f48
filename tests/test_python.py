"""test_python.py: the Python module (python/hdnet) against the hdnet tool and itself, with the
shipped model on the bundled photo: relight/delight/transfer/estimate-light equal the CLI's pixels
exactly; uint8 and float32 inputs agree; light=, preset= and direction= agree; decompose's maps have
the documented shapes and ranges; errors raise hdnet.Error with the library's message; calls release
the GIL (a Python thread keeps counting during one) and two threads sharing the model get the
serial results; white_balance=True keeps the albedo under a warm cast; a JPEG stored rotated with an EXIF orientation tag is relit upright, by the module
and by the tool alike; an unknown output extension is an error. Run by tests/python.sh: python3 test_python.py ROOT HDNET (in a scratch folder)."""
import os
import subprocess
import sys
import threading
import time

import numpy as np
import hdnet

root, tool = sys.argv[1], sys.argv[2]
photo_path = os.path.join(root, "examples", "astronaut.png")
failures = 0


def check(cond, what):
    global failures
    if not cond:
        print("test_python: FAILED: " + what, file=sys.stderr)
        failures += 1


def cli(*args):
    subprocess.run([tool] + list(args), check=True, stdout=subprocess.DEVNULL)


version = open(os.path.join(root, "include", "hdnet.h")).read()
want = ".".join(line.split()[2] for line in version.splitlines() if line.startswith("#define HDNET_VERSION_"))
check(hdnet.version() == want, "version %s, header %s" % (hdnet.version(), want))

photo = hdnet.imread(photo_path)
check(photo.shape == (512, 512, 3) and photo.dtype == np.float32, "imread shape %s" % (photo.shape,))
photo8 = np.round(photo * 255).astype(np.uint8)
model = hdnet.Model()

# relight: as the CLI, byte for byte; uint8 and float32 inputs; the three ways to give the light
cli("relight", photo_path, "--preset", "2", "-o", "cli_relit.pfm")
relit = model.relight(photo8, preset=2)
check(relit.shape == photo.shape and relit.dtype == np.float32, "relight shape %s" % (relit.shape,))
check(np.array_equal(relit, hdnet.imread("cli_relit.pfm")), "relight differs from hdnet relight --preset 2")
check(np.array_equal(relit, model.relight(photo, preset=2)), "uint8 and float32 inputs differ")
check(np.array_equal(relit, model.relight(photo, light=hdnet.light_preset(2))), "light= differs from preset=")
cli("relight", photo_path, "--dir", "40,20", "-o", "cli_dir.pfm")
check(np.array_equal(model.relight(photo, direction=(40, 20)), hdnet.imread("cli_dir.pfm")),
      "direction= differs from hdnet relight --dir 40,20")
check(np.abs(relit - photo).max() > 0.05, "relighting changed nothing")

# delight, estimate-light and transfer, as the CLI
cli("delight", photo_path, "-o", "cli_delit.pfm")
check(np.array_equal(model.delight(photo), hdnet.imread("cli_delit.pfm")), "delight differs from hdnet delight")
light = model.estimate_light(photo)
cli("estimate-light", photo_path, "-o", "cli.light.txt")
cli_light = np.array(open("cli.light.txt").read().split(), dtype=np.float32)
check(light.shape == (9,) and np.allclose(light, cli_light, atol=1e-5), "estimate_light %s, CLI %s" % (light, cli_light))
mirrored = np.ascontiguousarray(photo[:, ::-1])
moved = model.transfer(photo, mirrored)
check(np.array_equal(moved, model.relight(photo, light=model.estimate_light(mirrored))),
      "transfer is not relight under the reference's estimated light")

# decompose and align
albedo, shading, normal, dlight = model.decompose(photo)
s = model.size
check(albedo.shape == (s, s, 3) and shading.shape == (s, s, 1) and normal.shape == (s, s, 3), "decompose shapes")
check(albedo.min() >= 0 and albedo.max() <= 1 and shading.min() >= 0, "albedo or shading out of range")
check(np.allclose(np.linalg.norm(normal, axis=2), 1, atol=1e-4), "normals are not unit vectors")
# decompose's light is L-Net's; estimate_light is the face's own light, fitted to the shading over
# the skin and pulled toward the best ambient + distant light: not L-Net's, and rendered on the
# predicted normals (the SH basis of docs/spec.md section 2, written out here) it explains the
# predicted shading over the face's mask nearly as well as the best free 9-number light does
check(not np.array_equal(dlight, light), "estimate_light is decompose's (L-Net's) light")
c0, c1, c2, c3, c4 = 0.8862269254527579, 1.023326707946488, 0.8580855308097834, 0.2477079561003757, 0.4290427654048917
X, Y, Z = normal[..., 0], -normal[..., 2], normal[..., 1]
basis = np.stack([c0 + 0 * X, c1 * Y, c1 * Z, c1 * X, c2 * Y * X, c2 * Y * Z, c3 * (3 * Z * Z - 1), c2 * X * Z,
                  c4 * (X * X - Y * Y)], -1)
face_mask = hdnet.align(photo, s)[0].mask[..., 0] > 0.5
b, target = basis[face_mask].astype(np.float64), shading[..., 0][face_mask].astype(np.float64)
best = np.linalg.lstsq(b, target, rcond=None)[0]
rms = lambda l: float(np.sqrt(np.mean((b @ np.asarray(l, dtype=np.float64) - target) ** 2)))
check(face_mask.mean() > 0.2 and rms(light) < 1.25 * rms(best),
      "estimate_light renders the shading at RMSE %.4f over the mask, the best light %.4f" % (rms(light), rms(best)))
faces = hdnet.align(photo, size=128)
check(len(faces) == 1 and faces[0].texture.shape == (128, 128, 3) and faces[0].landmarks.shape == (468, 3),
      "align: %d faces" % len(faces))
a2, s2, n2, l2 = model.decompose(hdnet.align(photo, size=256)[0].texture, aligned=True)
check(np.array_equal(a2, albedo) and np.array_equal(l2, dlight), "decompose(aligned=True) of the texture differs")
# white_balance=True: the albedo of a warm-cast copy of the photo stays far closer to the photo's own
# (each with the same setting) than without. The photo is darkened first so that the cast is a pure
# cast: at full brightness x 1.2 clips the red of a quarter of the photo, which no balance gives back.
dim = (photo * 0.8).astype(np.float32)
warm = dim * np.array([1.2, 1.0, 0.8], np.float32)
balanced = hdnet.Model(white_balance=True)
drift_on = np.abs(balanced.decompose(warm)[0] - balanced.decompose(dim)[0])[face_mask].mean()
drift_off = np.abs(model.decompose(warm)[0] - model.decompose(dim)[0])[face_mask].mean()
check(drift_on < 0.5 * drift_off, "white_balance: albedo drift %.4f under a warm cast, %.4f without" % (drift_on, drift_off))
# the person segmentation of a face (Face.person, its window at person_origin): sure of the nose
f0 = faces[0]
check(f0.person is not None and f0.person.ndim == 3 and f0.person.shape[2] == 1, "Face.person is missing")
px, py = f0.person_origin
nx, ny = int(f0.landmarks[1, 0]) - px, int(f0.landmarks[1, 1]) - py
check(f0.person[ny, nx, 0] > 0.9, "Face.person at the nose: %.3f" % f0.person[ny, nx, 0])
# background="relight": as hdnet relight --background relight, byte for byte; the background moves
# by one factor per channel where the person is surely not (the default keeps it); a light from the
# side (at 40,20 the wall's factor is within 0.1 % of 1 since the normals take the fit's pose)
walled = hdnet.Model(background="relight")
check(walled.background == "relight" and model.background == "keep", "Model.background")
cli("relight", photo_path, "--dir", "70,20", "--background", "relight", "-o", "cli_wall.pfm")
wall = walled.relight(photo, direction=(70, 20))
check(np.array_equal(wall, hdnet.imread("cli_wall.pfm")), "background= differs from hdnet relight --background relight")
sure_bg = np.zeros(photo.shape[:2], bool)
h, w = f0.person.shape[:2]
sure_bg[py:py + h, px:px + w] = f0.person[..., 0] < 0.01
kept = model.relight(photo, direction=(70, 20))
check(sure_bg.sum() > 1000 and np.array_equal(kept[sure_bg], photo[sure_bg]), "the kept background changed")
ratio = wall[sure_bg] / np.maximum(photo[sure_bg], 1e-6)
lit = photo[sure_bg] > 0.05
spread = max(np.ptp(ratio[:, c][lit[:, c]]) for c in range(3))
check(spread < 0.02 and abs(np.median(ratio) - 1) > 0.01, "the background's factor spreads %.4f" % spread)
raises_bg = False
try:
    hdnet.Model(background="wall")
except ValueError:
    raises_bg = True
check(raises_bg, "background='wall' was accepted")
# shadows="none": as hdnet relight --shadows none, byte for byte; the default casts them: under a
# light from the side the relit face differs, darker where it does (the nose's shadow)
flat = hdnet.Model(shadows="none")
check(flat.shadows == "none" and model.shadows == "cast", "Model.shadows")
cli("relight", photo_path, "--dir", "70,20", "--shadows", "none", "-o", "cli_flat.pfm")
unshadowed = flat.relight(photo, direction=(70, 20))
check(np.array_equal(unshadowed, hdnet.imread("cli_flat.pfm")), "shadows= differs from hdnet relight --shadows none")
moved = np.abs(kept - unshadowed).max(axis=2) > 0.02
check(moved.sum() > 100 and (kept[moved] <= unshadowed[moved] + 1e-6).mean() > 0.9,
      "cast shadows: %d pixels moved, not mostly darker" % moved.sum())
try:
    hdnet.Model(shadows="soft")
    check(False, "shadows='soft' was accepted")
except ValueError:
    pass
tex = faces[0].texture
check(np.array_equal(model.relight(tex, preset=1, aligned=True), model.relight(tex, light=hdnet.light_preset(1), aligned=True)),
      "aligned relight: preset= and light= differ")

# errors carry the library's reason
def raises(exc, text, f, *a, **k):
    try:
        f(*a, **k)
    except exc as e:
        check(text in str(e), "error '%s' does not say '%s'" % (e, text))
        return
    check(False, "%s did not raise %s" % (f.__name__, exc.__name__))


raises(hdnet.Error, "missing.safetensors", hdnet.Model, "missing.safetensors")
raises(hdnet.Error, "no face found", hdnet.align, np.zeros((200, 160, 3), np.uint8))
raises(hdnet.Error, "no face found", model.relight, np.zeros((200, 160, 3), np.float32), preset=0)
raises(ValueError, "exactly one", model.relight, photo)
raises(ValueError, "H x W x 3", model.relight, np.zeros((4, 4, 5), np.float32), preset=0)
raises(TypeError, "uint8 or float32", model.relight, np.zeros((4, 4, 3), np.float64), preset=0)
raises(hdnet.Error, "0..6", hdnet.light_preset, 9)
raises(hdnet.Error, "out.tif", hdnet.imwrite, "out.tif", photo)
check(not os.path.exists("out.tif"), "a failed write left out.tif")

# the GIL is released during a call: a Python thread keeps counting
count, stop = [0], [False]


def counter():
    while not stop[0]:
        count[0] += 1


t = threading.Thread(target=counter)
t.start()
time.sleep(0.05)
before = count[0]
model.relight(photo, preset=4)
during = count[0] - before
stop[0] = True
t.join()
check(during > 1000, "a Python thread counted only %d during a call: the GIL was held" % during)

# two threads sharing the model get the serial results
serial = [model.relight(photo, preset=k) for k in (3, 5)]
out = [None, None]
threads = [threading.Thread(target=lambda i=i, k=k: out.__setitem__(i, model.relight(photo, preset=k)))
           for i, k in enumerate((3, 5))]
for th in threads:
    th.start()
for th in threads:
    th.join()
check(all(np.array_equal(out[i], serial[i]) for i in range(2)), "threads sharing a model differ from serial calls")

# EXIF orientation end to end: the photo stored turned a quarter anticlockwise, tagged 6 ("turn
# 90 degrees clockwise to show"), is found, relit and written upright, as the upright photo is.
def with_orientation(jpeg, o):
    tiff = b"II*\x00" + (8).to_bytes(4, "little") + (1).to_bytes(2, "little") + \
        (0x0112).to_bytes(2, "little") + (3).to_bytes(2, "little") + (1).to_bytes(4, "little") + \
        o.to_bytes(2, "little") + b"\x00\x00" + (0).to_bytes(4, "little")
    seg = b"Exif\x00\x00" + tiff
    return jpeg[:2] + b"\xff\xe1" + (len(seg) + 2).to_bytes(2, "big") + seg + jpeg[2:]


hdnet.imwrite("upright.jpg", photo)
hdnet.imwrite("stored.jpg", np.ascontiguousarray(np.rot90(photo, 1)))  # turned anticlockwise
open("tagged.jpg", "wb").write(with_orientation(open("stored.jpg", "rb").read(), 6))
upright = hdnet.imread("upright.jpg")
shown = hdnet.imread("tagged.jpg")
check(shown.shape == upright.shape and np.abs(shown - upright).mean() < 0.01, "the tagged JPEG is not read upright")
r_up, r_tag = model.relight(upright, preset=2), model.relight(shown, preset=2)
diff = np.abs(r_up - r_tag).mean()
check(r_tag.shape == upright.shape and diff < 0.01, "relit tagged photo differs from the upright one by %.4f" % diff)
cli("relight", "tagged.jpg", "--preset", "2", "-o", "cli_tagged.pfm")
check(np.array_equal(hdnet.imread("cli_tagged.pfm"), r_tag), "hdnet relight of the tagged JPEG differs from the module's")

hdnet.imwrite("relit.png", relit)
err = np.abs(hdnet.imread("relit.png") - np.clip(relit, 0, 1)).max()  # PNG holds [0, 1]; the blend may overshoot
check(err <= 1 / 255 + 1e-6, "imwrite/imread PNG round trip: error %g" % err)
print("test_python: %s, relight/delight/transfer/estimate-light as the CLI, counted %d during a call, %s" %
      (hdnet.version(), during, "all checks passed" if not failures else "%d FAILED" % failures))
sys.exit(1 if failures else 0)
