"""hdnet: face inverse rendering and relighting (HD-Net), from Python.

A thin layer over the shared library libhdnet.so through ctypes (docs/python.md). Images are
numpy arrays H x W x 3, uint8 (0..255) or float32 (0..1); results are float32 arrays H x W x C.
Every call releases the GIL while the library works (ctypes does so for each foreign call), and
one Model serves any number of Python threads at once. Errors raise hdnet.Error with the
library's one-line reason.

    import hdnet, numpy as np
    model = hdnet.Model()                       # the shipped default model
    relit = model.relight(photo, preset=2)      # photo: H x W x 3 uint8
    albedo, shading, normal, light = model.decompose(face_texture, aligned=True)
"""
import ctypes
import ctypes.util
import os

import numpy as np

__all__ = ["Error", "Model", "Face", "align", "imread", "imwrite", "version", "light_from_direction",
           "light_preset", "PRESETS"]

SH_COEFFS = 9
PRESETS = 7
FACE_LANDMARKS = 468


class Error(RuntimeError):
    """A failure reported by libhdnet; the message is the library's reason."""


class _Image(ctypes.Structure):
    _fields_ = [("width", ctypes.c_int), ("height", ctypes.c_int), ("channels", ctypes.c_int),
                ("data", ctypes.POINTER(ctypes.c_float))]


class _Decomposition(ctypes.Structure):
    _fields_ = [("albedo", _Image), ("shading", _Image), ("normal", _Image), ("reconstruction", _Image),
                ("light", ctypes.c_float * SH_COEFFS), ("camera_tint", ctypes.c_float * 3)]


class _AlignedFace(ctypes.Structure):
    _fields_ = [("size", ctypes.c_int), ("texture", _Image), ("mask", _Image), ("normal", _Image),
                ("landmarks", (ctypes.c_float * 3) * FACE_LANDMARKS),
                ("photo_width", ctypes.c_int), ("photo_height", ctypes.c_int),
                ("score", ctypes.c_float), ("box", ctypes.c_float * 4),
                ("scale", ctypes.c_float), ("rotation", ctypes.c_float * 9), ("translation", ctypes.c_float * 3),
                ("depth_sign", ctypes.c_float), ("fit_rms", ctypes.c_float),
                ("person", _Image), ("person_x0", ctypes.c_int), ("person_y0", ctypes.c_int)]


def _load_library():
    """libhdnet: $HDNET_LIBRARY, else beside this package (installed: PREFIX/lib; source tree:
    build/), else the system's search path."""
    here = os.path.dirname(os.path.abspath(__file__))
    candidates = []
    if os.environ.get("HDNET_LIBRARY"):
        candidates.append(os.environ["HDNET_LIBRARY"])
    candidates += [os.path.join(here, "..", "..", "..", "libhdnet.so.0"),   # PREFIX/lib/pythonX.Y/dist-packages/hdnet
                   os.path.join(here, "..", "..", "build", "libhdnet.so.0"),  # the source tree
                   ctypes.util.find_library("hdnet") or "libhdnet.so.0"]
    errors = []
    for path in candidates:
        if os.sep in path and not os.path.exists(path):
            continue
        try:
            return ctypes.CDLL(path)
        except OSError as e:
            errors.append(str(e))
    raise ImportError("hdnet: cannot load libhdnet.so (set HDNET_LIBRARY): " + "; ".join(errors or ["not found"]))


_lib = _load_library()
_P = ctypes.POINTER
_img_p = _P(_Image)
_light_t = ctypes.c_float * SH_COEFFS


def _sig(name, restype, *argtypes):
    f = getattr(_lib, name)
    f.restype = restype
    f.argtypes = list(argtypes)
    return f


_st = ctypes.c_int
_hd_error = _sig("hd_error", ctypes.c_char_p)
_hd_version = _sig("hd_version", ctypes.c_char_p)
_image_alloc = _sig("hd_image_alloc", _st, _img_p, ctypes.c_int, ctypes.c_int, ctypes.c_int)
_image_free = _sig("hd_image_free", None, _img_p)
_model_load = _sig("hd_model_load", _st, ctypes.c_char_p, _P(ctypes.c_void_p))
_model_free = _sig("hd_model_free", None, ctypes.c_void_p)
_model_size = _sig("hd_model_size", ctypes.c_int, ctypes.c_void_p)
_model_decompose = _sig("hd_model_decompose", _st, ctypes.c_void_p, _img_p, ctypes.c_int, _P(_Decomposition))
_decomposition_free = _sig("hd_decomposition_free", None, _P(_Decomposition))
_model_set_white_balance = _sig("hd_model_set_white_balance", _st, ctypes.c_void_p, ctypes.c_int)
_model_set_background = _sig("hd_model_set_background", _st, ctypes.c_void_p, ctypes.c_int)
_model_background = _sig("hd_model_background", ctypes.c_int, ctypes.c_void_p)
_model_set_shadows = _sig("hd_model_set_shadows", _st, ctypes.c_void_p, ctypes.c_int)
_model_shadows = _sig("hd_model_shadows", ctypes.c_int, ctypes.c_void_p)
_aligner_load = _sig("hd_aligner_load", _st, _P(ctypes.c_void_p))
_aligner_free = _sig("hd_aligner_free", None, ctypes.c_void_p)
_aligner_run = _sig("hd_aligner_run", _st, ctypes.c_void_p, _img_p, ctypes.c_int, _P(_P(_AlignedFace)),
                    _P(ctypes.c_int))
_aligned_faces_free = _sig("hd_aligned_faces_free", None, _P(_AlignedFace), ctypes.c_int)
_relight_face = _sig("hd_relight_face", _st, ctypes.c_void_p, _img_p, _img_p, _light_t, ctypes.c_int, _img_p)
_delight_face = _sig("hd_delight_face", _st, ctypes.c_void_p, _img_p, _img_p, _img_p)
_estimate_light = _sig("hd_estimate_light", _st, ctypes.c_void_p, _img_p, _light_t)
_relight_photo = _sig("hd_relight_photo", _st, ctypes.c_void_p, ctypes.c_void_p, _img_p, _P(_light_t), ctypes.c_int,
                      ctypes.c_int, _img_p, _img_p, _P(ctypes.c_int))
_decompose_photo = _sig("hd_decompose_photo", _st, ctypes.c_void_p, ctypes.c_void_p, _img_p, _P(_Decomposition),
                        ctypes.c_void_p)
_transfer_photo = _sig("hd_transfer_photo", _st, ctypes.c_void_p, ctypes.c_void_p, _img_p, _img_p, ctypes.c_int,
                       _img_p, _P(ctypes.c_int))
_estimate_light_photo = _sig("hd_estimate_light_photo", _st, ctypes.c_void_p, ctypes.c_void_p, _img_p, _light_t,
                             _P(ctypes.c_int))
_light_from_direction = _sig("hd_light_from_direction", None, ctypes.c_float, ctypes.c_float, ctypes.c_float,
                             ctypes.c_float, _light_t)
_light_preset = _sig("hd_light_preset", _st, ctypes.c_int, _light_t)
_image_read_as = _sig("hd_image_read_as", _st, ctypes.c_char_p, ctypes.c_int, _img_p)
_image_write_picture = _sig("hd_image_write_picture", _st, ctypes.c_char_p, _img_p)

HD_BRIGHTNESS_KEEP, HD_BRIGHTNESS_FREE = 0, 1


def _check(status):
    if status != 0:
        raise Error(_hd_error().decode("utf-8", "replace"))


def version():
    """The linked library's version, "MAJOR.MINOR.PATCH"."""
    return _hd_version().decode()


def _to_image(array, name="image"):
    """An H x W x 3 (or H x W) uint8 / float32 array as a planar float32 hd_image that owns a copy.
    Returns (hd_image, keep-alive buffer)."""
    a = np.asarray(array)
    if a.ndim == 2:
        a = a[:, :, None]
    if a.ndim != 3 or a.shape[2] not in (1, 3) or a.shape[0] < 1 or a.shape[1] < 1:
        raise ValueError("%s: expected an H x W x 3 array, got shape %s" % (name, a.shape))
    if a.dtype == np.uint8:
        f = a.astype(np.float32) / np.float32(255)
    elif a.dtype == np.float32:
        f = a
    else:
        raise TypeError("%s: expected uint8 or float32 values, got %s" % (name, a.dtype))
    if not np.all(np.isfinite(f)):
        raise ValueError("%s: holds NaN or infinity" % name)
    planar = np.ascontiguousarray(np.transpose(f, (2, 0, 1)), dtype=np.float32)
    img = _Image(a.shape[1], a.shape[0], a.shape[2], planar.ctypes.data_as(_P(ctypes.c_float)))
    return img, planar


def _from_image(img):
    """A library-owned hd_image as an H x W x C float32 numpy array (copied)."""
    n = img.width * img.height * img.channels
    planar = np.ctypeslib.as_array(img.data, shape=(n,)).reshape(img.channels, img.height, img.width)
    return np.transpose(planar, (1, 2, 0)).copy()  # always a copy: the library frees its image next


def _take_image(img):
    """_from_image, then frees the library's image."""
    try:
        return _from_image(img)
    finally:
        _image_free(ctypes.byref(img))


def imread(path):
    """A PNG, JPEG or PFM file as an H x W x 3 float32 array in [0, 1] (the library's reader)."""
    img = _Image()
    _check(_image_read_as(os.fsencode(path), 3, ctypes.byref(img)))
    return _take_image(img)


def imwrite(path, array):
    """Writes an H x W x 3 (or x 1) array with the library's writer: the format follows the
    extension (docs/library.md); written whole or not at all."""
    img, keep = _to_image(array, "array")
    _check(_image_write_picture(os.fsencode(path), ctypes.byref(img)))


def light_from_direction(azimuth, elevation, intensity=1.5, ambient=0.5):
    """The 9 SH coefficients of a gray light from (azimuth, elevation) in degrees (docs/conventions.md)."""
    light = _light_t()
    _light_from_direction(azimuth, elevation, intensity, ambient, light)
    return np.array(light, dtype=np.float32)


def light_preset(k):
    """Built-in light k in 0..6."""
    light = _light_t()
    _check(_light_preset(int(k), light))
    return np.array(light, dtype=np.float32)


def _light_arg(light, preset, direction):
    given = sum(x is not None for x in (light, preset, direction))
    if given != 1:
        raise ValueError("give exactly one of light=, preset= and direction=")
    if preset is not None:
        return light_preset(preset)
    if direction is not None:
        return light_from_direction(*direction)
    ls = np.asarray(light, dtype=np.float32).reshape(-1)
    if ls.shape != (SH_COEFFS,) or not np.all(np.isfinite(ls)):
        raise ValueError("light: expected 9 finite SH coefficients")
    return ls


class Face:
    """One face found in a photo: texture (S x S x 3), mask (S x S x 1), normal (S x S x 3, camera
    frame), landmarks (468 x 3: photo x, y and depth), box (x0, y0, x1, y1) and score; person, the
    probability that each pixel of a window of the photo shows this face's person (h x w x 1, the
    person segmentation; None where it did not see the face) and person_origin, the window's top-left
    photo pixel (x0, y0)."""

    def __init__(self, f):
        self.texture = _from_image(f.texture)
        self.mask = _from_image(f.mask)
        self.normal = _from_image(f.normal)
        self.person = _from_image(f.person) if f.person.data else None
        self.person_origin = (f.person_x0, f.person_y0)
        self.landmarks = np.array(f.landmarks, dtype=np.float32)
        self.box = tuple(f.box)
        self.score = f.score


class _Aligner:
    """The face detector and landmark models, loaded once (thread-safe, shared)."""

    def __init__(self):
        p = ctypes.c_void_p()
        _check(_aligner_load(ctypes.byref(p)))
        self._p = p

    def __del__(self):
        if getattr(self, "_p", None):
            _aligner_free(self._p)
            self._p = None

    def run(self, photo, size):
        img, keep = _to_image(photo, "photo")
        faces = _P(_AlignedFace)()
        count = ctypes.c_int()
        _check(_aligner_run(self._p, ctypes.byref(img), size, ctypes.byref(faces), ctypes.byref(count)))
        try:
            return [Face(faces[i]) for i in range(count.value)]
        finally:
            _aligned_faces_free(faces, count.value)


_shared_aligner = None


def _aligner():
    global _shared_aligner
    if _shared_aligner is None:
        _shared_aligner = _Aligner()
    return _shared_aligner


def align(photo, size=256):
    """Every face of a photo (H x W x 3), aligned at texture side `size`: a list of Face, best first.
    No face raises Error ("no face found ...")."""
    return _aligner().run(photo, int(size))


class Model:
    """An HD-Net model: Model() loads the shipped default, Model(path) a .safetensors file.

    Methods take a photo (H x W x 3: its faces are found, processed and blended back; the result has
    the photo's size) or, with aligned=True, an aligned face texture (the result is a texture).
    keep_brightness (relight, transfer): match the input's mean brightness (the default).
    white_balance=True: divide the colour cast read from the whites of the eyes out of each face
    before decomposing it (hd_model_set_white_balance; off by default).
    background="relight": a photo's background is relit too, as a flat wall under the same light,
    and the body below the chin with the head (hd_model_set_background; "keep", the default, leaves
    both bit for bit).
    shadows="none": no shadows cast by the face on itself (hd_model_set_shadows; "cast", the
    default, darkens where the nose or the brows hide the new light and evens out where they hid
    the old one)."""

    _BACKGROUNDS = {"keep": 0, "relight": 1}
    _SHADOWS = {"cast": 0, "none": 1}

    def __init__(self, path=None, white_balance=False, background="keep", shadows="cast"):
        if background not in self._BACKGROUNDS:
            raise ValueError("background: expected 'keep' or 'relight', got %r" % (background,))
        if shadows not in self._SHADOWS:
            raise ValueError("shadows: expected 'cast' or 'none', got %r" % (shadows,))
        p = ctypes.c_void_p()
        _check(_model_load(None if path is None else os.fsencode(path), ctypes.byref(p)))
        self._p = p
        self.size = _model_size(p)
        if white_balance:
            _check(_model_set_white_balance(p, 1))
        _check(_model_set_background(p, self._BACKGROUNDS[background]))
        _check(_model_set_shadows(p, self._SHADOWS[shadows]))

    @property
    def background(self):
        """What relighting a photo does to its background: "keep" or "relight"."""
        return "relight" if _model_background(self._p) == 1 else "keep"

    @property
    def shadows(self):
        """Whether relighting a photo casts the face's shadows on itself: "cast" or "none"."""
        return "none" if _model_shadows(self._p) == 1 else "cast"

    def __del__(self):
        if getattr(self, "_p", None):
            _model_free(self._p)
            self._p = None

    def decompose(self, img, aligned=False):
        """(albedo H x W x 3, shading H x W x 1, normal H x W x 3, light (9,)) at the model's size,
        of an aligned texture or of the best face of a photo."""
        im, keep = _to_image(img)
        d = _Decomposition()
        if aligned:
            _check(_model_decompose(self._p, ctypes.byref(im), 1, ctypes.byref(d)))
        else:
            _check(_decompose_photo(self._p, _aligner()._p, ctypes.byref(im), ctypes.byref(d), None))
        try:
            return (_from_image(d.albedo), _from_image(d.shading), _from_image(d.normal),
                    np.array(d.light, dtype=np.float32))
        finally:
            _decomposition_free(ctypes.byref(d))

    def estimate_light(self, img, aligned=False):
        """The face's own light, 9 SH coefficients (the best face of a photo): the least-squares light of
        the predicted shading on the predicted normals over the skin (the face below the nose weighted
        a quarter), pulled toward the best ambient + distant light of that shading (not decompose's light, which is L-Net's), as `hdnet
        estimate-light` writes it and the relighting rule uses it."""
        im, keep = _to_image(img)
        light = _light_t()
        if aligned:
            _check(_estimate_light(self._p, ctypes.byref(im), light))
        else:
            _check(_estimate_light_photo(self._p, _aligner()._p, ctypes.byref(im), light, None))
        return np.array(light, dtype=np.float32)

    def _relight_under(self, img, light, keep_brightness, aligned):
        im, keep = _to_image(img)
        l = _light_t(*[float(x) for x in light])
        out = _Image()
        mode = HD_BRIGHTNESS_KEEP if keep_brightness else HD_BRIGHTNESS_FREE
        if aligned:
            _check(_relight_face(self._p, ctypes.byref(im), None, l, mode, ctypes.byref(out)))
        else:
            _check(_relight_photo(self._p, _aligner()._p, ctypes.byref(im), ctypes.pointer(l), 1, mode,
                                  ctypes.byref(out), None, None))
        return _take_image(out)

    def relight(self, img, light=None, preset=None, direction=None, keep_brightness=True, aligned=False):
        """The face(s) relit under one of: light= (9 SH coefficients), preset= (0..6) or
        direction=(azimuth, elevation) in degrees."""
        return self._relight_under(img, _light_arg(light, preset, direction), keep_brightness, aligned)

    def delight(self, img, aligned=False):
        """The face(s) under flat light: the albedo (outside the faces, the photo)."""
        im, keep = _to_image(img)
        out = _Image()
        if aligned:
            _check(_delight_face(self._p, ctypes.byref(im), None, ctypes.byref(out)))
        else:
            _check(_relight_photo(self._p, _aligner()._p, ctypes.byref(im), None, 0, HD_BRIGHTNESS_KEEP, None,
                                  ctypes.byref(out), None))
        return _take_image(out)

    def transfer(self, img, reference, keep_brightness=True, aligned=False):
        """img relit under the light estimated for the face in `reference` (same kind as img)."""
        if aligned:
            return self._relight_under(img, self.estimate_light(reference, True), keep_brightness, True)
        im, keep = _to_image(img)
        ref, keep_ref = _to_image(reference, "reference")
        out = _Image()
        mode = HD_BRIGHTNESS_KEEP if keep_brightness else HD_BRIGHTNESS_FREE
        _check(_transfer_photo(self._p, _aligner()._p, ctypes.byref(im), ctypes.byref(ref), mode, ctypes.byref(out),
                               None))
        return _take_image(out)
