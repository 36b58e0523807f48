#!/usr/bin/env python3
"""make_broken.py: writes tests/data/broken/, a corpus of small broken files that `hdnet info`
must refuse with a clear error (exit status 1 or 2, never a signal). Run once with python3 from
anywhere; the files are committed. Every file is built here from first principles (PNG chunks
with zlib and CRC-32, a minimal baseline JPEG, PFM text headers, safetensors headers, light
files), so the corpus needs nothing but the Python standard library.

Usage: python3 tests/data/make_broken.py [OUTPUT_DIR]   (default: broken/ beside this script)
"""
import os
import struct
import sys
import zlib

OUT = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(os.path.abspath(__file__)), "broken")
os.makedirs(OUT, exist_ok=True)
written = []


def put(name, data):
    if isinstance(data, str):
        data = data.encode()
    with open(os.path.join(OUT, name), "wb") as f:
        f.write(data)
    written.append(name)


# ---------------------------------------------------------------- PNG

PNG_SIG = b"\x89PNG\r\n\x1a\n"


def chunk(kind, body, crc=None):
    if crc is None:
        crc = zlib.crc32(kind + body) & 0xFFFFFFFF
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", crc)


def ihdr(w, h, depth=8, ctype=2, interlace=0):
    return chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, depth, ctype, 0, 0, interlace))


def rgb_rows(w, h, filter_byte=0):
    """Filtered scanlines of a w x h 8-bit RGB gradient."""
    out = bytearray()
    for y in range(h):
        out.append(filter_byte)
        for x in range(w):
            out += bytes(((x * 255) // max(w - 1, 1), (y * 255) // max(h - 1, 1), 77))
    return bytes(out)


def png(w, h, rows, depth=8, ctype=2, extra=b""):
    return PNG_SIG + ihdr(w, h, depth, ctype) + extra + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b"")


good = png(16, 16, rgb_rows(16, 16))
idat_at = good.index(b"IDAT") - 4
iend_at = good.index(b"IEND") - 4

put("png_empty.png", b"")
put("png_signature_only.png", PNG_SIG)
put("png_cut_in_signature.png", good[:5])
put("png_cut_in_ihdr.png", good[:20])
put("png_cut_after_ihdr.png", good[:idat_at])
put("png_cut_in_idat.png", good[: idat_at + 8 + (iend_at - idat_at - 12) // 2])
put("png_cut_before_iend.png", good[:iend_at])
put("png_wrong_magic.png", b"\x89PNX\r\n\x1a\n" + good[8:])
bad = bytearray(good)
bad[29] ^= 0xFF  # last byte of the IHDR CRC
put("png_bad_crc_ihdr.png", bytes(bad))
bad = bytearray(good)
bad[iend_at - 1] ^= 0xFF  # last byte of the IDAT CRC
put("png_bad_crc_idat.png", bytes(bad))
put("png_width_0.png", png(0, 16, b""))
put("png_width_100000.png", png(100000, 1, rgb_rows(1, 1)))
put("png_size_overflow.png", png(65535, 65535, rgb_rows(1, 1), depth=16, ctype=6))
put("png_huge_claim.png", png(16000, 16000, rgb_rows(4, 4)))  # lying: 768 MB claimed in ~100 bytes
put("png_lying_ihdr.png", PNG_SIG + ihdr(64, 64) + chunk(b"IDAT", zlib.compress(rgb_rows(8, 8))) + chunk(b"IEND", b""))
put("png_bad_color_type.png", png(4, 4, rgb_rows(4, 4), ctype=5))
put("png_bad_bit_depth.png", png(4, 4, rgb_rows(4, 4), depth=4, ctype=2))
put("png_no_idat.png", PNG_SIG + ihdr(4, 4) + chunk(b"IEND", b""))
put("png_idat_not_zlib.png", PNG_SIG + ihdr(4, 4) + chunk(b"IDAT", b"this is not deflate data") + chunk(b"IEND", b""))
put("png_palette_without_plte.png", png(4, 4, bytes([0, 0, 0, 0, 0] * 4), ctype=3))
put("png_bad_filter.png", png(4, 4, rgb_rows(4, 4, filter_byte=9)))

# ---------------------------------------------------------------- JPEG
# A minimal baseline JPEG: all quantisers 1, one-code Huffman tables (DC category 0 = '0',
# AC EOB = '0'), so each 8x8 block of flat mid gray costs two zero bits.


def seg(marker, body):
    return bytes([0xFF, marker]) + struct.pack(">H", len(body) + 2) + body


def jpeg(w, h, ncomp=1, scan_bytes=None):
    dqt = seg(0xDB, bytes([0x00]) + bytes([1] * 64))
    sof = seg(0xC0, struct.pack(">BHHB", 8, h, w, ncomp) + b"".join(bytes([i + 1, 0x11, 0]) for i in range(ncomp)))
    counts = bytes([1] + [0] * 15)
    dht = seg(0xC4, bytes([0x00]) + counts + bytes([0])) + seg(0xC4, bytes([0x10]) + counts + bytes([0]))
    sos = seg(0xDA, bytes([ncomp]) + b"".join(bytes([i + 1, 0x00]) for i in range(ncomp)) + bytes([0, 63, 0]))
    blocks = ((w + 7) // 8) * ((h + 7) // 8) * ncomp
    if scan_bytes is None:
        scan_bytes = bytes((2 * blocks + 7) // 8)
    return b"\xFF\xD8" + dqt + sof + dht + sos + scan_bytes + b"\xFF\xD9"


good_jpeg = jpeg(128, 128)
sos_at = good_jpeg.index(b"\xFF\xDA")
put("jpeg_soi_only.jpg", b"\xFF\xD8\xFF")
put("jpeg_cut_in_header.jpg", good_jpeg[:40])
put("jpeg_cut_in_scan.jpg", good_jpeg[: sos_at + 14 + 20])
put("jpeg_no_eoi_no_scan.jpg", good_jpeg[:sos_at])
put("jpeg_sof_zero_size.jpg", jpeg(0, 0))
put("jpeg_sof_huge.jpg", jpeg(60000, 60000, scan_bytes=bytes(16)))
put("jpeg_huge_claim_cut.jpg", jpeg(16000, 16000, scan_bytes=bytes(16))[:-2])  # 16000^2 claimed, 16 bytes of scan
garbage = bytearray(good_jpeg)
sof_at = good_jpeg.index(b"\xFF\xC0")
garbage[sof_at + 4: sof_at + 14] = b"\xEE" * 10  # precision, size and components all garbage
put("jpeg_garbage_sof.jpg", bytes(garbage))
put("jpeg_cmyk.jpg", jpeg(8, 8, ncomp=4))

# ---------------------------------------------------------------- PFM

put("pfm_negative_size.pfm", b"PF\n-4 4\n-1.0\n" + bytes(4 * 4 * 12))
put("pfm_huge_size.pfm", b"PF\n100000 100000\n-1.0\n" + bytes(64))
put("pfm_zero_size.pfm", b"Pf\n0 3\n-1.0\n")
put("pfm_truncated.pfm", b"Pf\n4 4\n-1.0\n" + bytes(20))
put("pfm_text_scale.pfm", b"Pf\n2 2\nbright\n" + bytes(16))
put("pfm_zero_scale.pfm", b"Pf\n2 2\n0.0\n" + bytes(16))
put("pfm_header_only.pfm", b"PF\n")
put("pfm_nan.pfm", b"Pf\n2 1\n-1.0\n" + struct.pack("<ff", 0.5, float("nan")))
put("pfm_size_not_number.pfm", b"PF\n4x 4\n-1.0\n" + bytes(4 * 4 * 12))

# ---------------------------------------------------------------- safetensors


def st(header, data=b"", length=None):
    h = header.encode()
    return struct.pack("<Q", len(h) if length is None else length) + h + data


def tensor(dtype="F32", shape=(2,), offsets=(0, 8)):
    return '{"dtype":"%s","shape":[%s],"data_offsets":[%d,%d]}' % (dtype, ",".join(map(str, shape)), *offsets)


put("st_empty.safetensors", b"")
put("st_too_short.safetensors", b"\x10\x00\x00")
put("st_header_length_past_end.safetensors", st('{"a":%s}' % tensor(), bytes(8), length=4096))
put("st_header_length_huge.safetensors", st('{"a":%s}' % tensor(), bytes(8), length=(1 << 63) + 5))
put("st_header_not_json.safetensors", st("this is not JSON at all", bytes(8)))
put("st_bad_json.safetensors", st('{"a":{"dtype":"F32","shape":[2],"data_offsets":[0,8]', bytes(8)))
put("st_header_is_array.safetensors", st("[1, 2, 3]"))
put("st_shape_offset_mismatch.safetensors", st('{"w":%s}' % tensor(shape=(3,), offsets=(0, 8)), bytes(12)))
put("st_overlapping.safetensors",
    st('{"p":%s,"q":%s}' % (tensor(offsets=(0, 8)), tensor(offsets=(4, 12))), bytes(12)))
put("st_offsets_past_end.safetensors", st('{"w":%s}' % tensor(shape=(4,), offsets=(8, 24)), bytes(16)))
put("st_dtype_f16.safetensors", st('{"h":%s}' % tensor(dtype="F16", offsets=(0, 4)), bytes(4)))
put("st_negative_shape.safetensors", st('{"n":%s}' % tensor(shape=(-2,), offsets=(0, 0))))
put("st_shape_overflow.safetensors",
    st('{"n":%s}' % tensor(shape=(1 << 32, 1 << 32, 1 << 32), offsets=(0, 4)), bytes(4)))
put("st_metadata_not_string.safetensors", st('{"__metadata__":{"width":48,"size":"256"}}'))
put("st_duplicate_names.safetensors",
    st('{"d":%s,"d":%s}' % (tensor(shape=(1,), offsets=(0, 4)), tensor(shape=(1,), offsets=(4, 8))), bytes(8)))
put("st_offsets_reversed.safetensors", st('{"b":%s}' % tensor(shape=(0,), offsets=(8, 4)), bytes(8)))

# ---------------------------------------------------------------- light files (SPEC section 2)

LIGHT = ["1.084125", "-0.464268", "0.028378", "0.676529", "-0.359407", "0.047910", "-0.228005", "-0.081260",
         "0.288108"]
put("light_8_numbers.light.txt", "\n".join(LIGHT[:8]) + "\n")
put("light_10_numbers.light.txt", "\n".join(LIGHT + ["0.5"]) + "\n")
put("light_nan.light.txt", "\n".join(LIGHT[:4] + ["nan"] + LIGHT[5:]) + "\n")
put("light_inf.light.txt", "\n".join(LIGHT[:6] + ["inf"] + LIGHT[7:]) + "\n")
put("light_text_in_middle.light.txt", "\n".join(LIGHT[:3] + ["bright"] + LIGHT[3:]) + "\n")
put("light_empty.light.txt", "")

# ---------------------------------------------------------------- issue 15's audit findings

# a PFM of 84 bytes declaring 16384 x 16384 (within the side limit and, with HDNET_MAX_PIXELS
# raised, the pixel limit): refused from the file size before 3.2 GB are reserved
put("pfm_16k_bomb_84_bytes.pfm", b"PF\n16384 16384\n-1.0\n" + bytes(84 - len(b"PF\n16384 16384\n-1.0\n")))
# a 1-bit gray PNG of 12000 x 9000 zeros (108 megapixels, 14 KB): over the default pixel limit,
# refused from its header before 432 MB are allocated and the rows inflated
zero_rows = zlib.compress(b"".join(b"\x00" + bytes((12000 + 7) // 8) for _ in range(9000)), 9)
put("png_108_megapixels_1bit.png",
    PNG_SIG + ihdr(12000, 9000, depth=1, ctype=0) + chunk(b"IDAT", zero_rows) + chunk(b"IEND", b""))
# a light whose shading overflows float (3.4e38 is finite, its shading is not)
put("light_3e38.light.txt", "\n".join(["3.4e38"] + LIGHT[1:]) + "\n")
# a terminal escape inside a token: refused, and printed as \x1b
put("light_escape_sequence.light.txt", "\n".join(LIGHT[:2] + ["\x1b[2J\x1b[31mred"] + LIGHT[3:]) + "\n")


# ---------------------------------------------------------------- fuzzer findings (tests/fuzz/)

# fuzz_serve: a frame header of width 0 and height 128 behind a DQT; the server's header probe
# took it as a size (0 pixels, under any cap) before refusing zero sides
put("jpeg_probe_width_0.jpg",
    b"\xff\xd8\xff\xdb\x00\x43\x00" + bytes([1] * 64) + b"\xff\xc0\x00\x0b\x08\x00\x80\x00\x00\x01\x01\x11\x00"
    + bytes(16))

print("wrote %d files into %s" % (len(written), OUT))
