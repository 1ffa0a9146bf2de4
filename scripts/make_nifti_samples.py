#!/usr/bin/env python3
"""Writes the small NIfTI files the tests and the fuzzer start from, field by field from the
NIfTI-1 and NIfTI-2 standards (no NIfTI package needed): for the tests a ball of radius N/3
in a 16^3 grid as uint8 (.nii.gz) and the same ball with anisotropic spacing
1 x 1 x 2.5 mm; for the fuzzer (inputs under 4 KB) the same in 8^3 as uint8 (.nii,
.nii.gz), int16 labels and NIfTI-2 float32. Usage: scripts/make_nifti_samples.py  (from the repository)."""
import gzip
import struct

N = 16


def ball(value_in, value_out):
    c, r = (N - 1) / 2, N / 3
    return [value_in if (i - c) ** 2 + (j - c) ** 2 + (k - c) ** 2 <= r * r else value_out
            for k in range(N) for j in range(N) for i in range(N)]  # x fastest


def nifti1(values, fmt, datatype, bitpix, spacing=(1.0, 1.0, 1.0)):
    h = bytearray(348)
    struct.pack_into("<i", h, 0, 348)
    struct.pack_into("<8h", h, 40, 3, N, N, N, 1, 1, 1, 1)
    struct.pack_into("<hh", h, 70, datatype, bitpix)
    struct.pack_into("<8f", h, 76, 1.0, *spacing, 0, 0, 0, 0)
    struct.pack_into("<f", h, 108, 352.0)      # vox_offset
    h[123] = 2                                 # xyzt_units: mm
    h[344:348] = b"n+1\0"
    return bytes(h) + bytes(4) + struct.pack("<%d%s" % (len(values), fmt), *values)


def nifti2(values, fmt, datatype, bitpix):
    h = bytearray(540)
    struct.pack_into("<i", h, 0, 540)
    h[4:12] = b"n+2\0\r\n\x1a\n"
    struct.pack_into("<hh", h, 12, datatype, bitpix)
    struct.pack_into("<8q", h, 16, 3, N, N, N, 1, 1, 1, 1)
    struct.pack_into("<8d", h, 104, 1.0, 1.0, 1.0, 1.0, 0, 0, 0, 0)
    struct.pack_into("<q", h, 168, 544)        # vox_offset
    struct.pack_into("<i", h, 500, 2)          # xyzt_units: mm
    return bytes(h) + bytes(4) + struct.pack("<%d%s" % (len(values), fmt), *values)


def write(path, data):
    with (gzip.open(path, "wb") if path.endswith(".gz") else open(path, "wb")) as f:
        f.write(data)


mask = nifti1(ball(1, 0), "B", 2, 8)
write("tests/data/ball.nii.gz", mask)
write("tests/data/ball_anisotropic.nii", nifti1(ball(1, 0), "B", 2, 8, (1.0, 1.0, 2.5)))
N = 8
mask = nifti1(ball(1, 0), "B", 2, 8)
write("tests/fuzz/volume_corpus/ball_u1.nii", mask)
write("tests/fuzz/volume_corpus/ball_u1.nii.gz", mask)
write("tests/fuzz/volume_corpus/labels_i2.nii", nifti1(ball(3, -1), "h", 4, 16))
write("tests/fuzz/volume_corpus/ball_f4_v2.nii", nifti2(ball(1.0, 0.0), "f", 16, 32))
