#!/usr/bin/env python3
"""A minimal DNG writer for synthetic captures (tifffile): one uncompressed 16-bit Bayer image.

The camera's native RGB is linear sRGB scaled by `neutral` (its response to white), so
ColorMatrix1 = diag(neutral) · (XYZ -> linear sRGB) and AsShotNeutral = neutral: a raw converter
that applies the white balance and the matrix recovers linear sRGB exactly.

    python3 scripts/captures/dng.py FIXTURE.dng     # the test fixture of cdrf-fit's tests/image_io.rs
"""
import sys
from fractions import Fraction

import numpy as np
import tifffile

# Linear sRGB (D65) -> XYZ, and its inverse.
SRGB_TO_XYZ = np.array([[0.4124564, 0.3575761, 0.1804375],
                        [0.2126729, 0.7151522, 0.0721750],
                        [0.0193339, 0.1191920, 0.9503041]])
XYZ_TO_SRGB = np.linalg.inv(SRGB_TO_XYZ)


def _rationals(values, signed=False, denominator=10000):
    out = []
    for v in values:
        f = Fraction(float(v)).limit_denominator(denominator)
        out += [f.numerator, f.denominator]
    return out


def mosaic_rggb(rgb):
    """H x W x 3 (even H, W) -> H x W Bayer RGGB plane."""
    h, w, _ = rgb.shape
    out = np.empty((h, w), rgb.dtype)
    out[0::2, 0::2] = rgb[0::2, 0::2, 0]
    out[0::2, 1::2] = rgb[0::2, 1::2, 1]
    out[1::2, 0::2] = rgb[1::2, 0::2, 1]
    out[1::2, 1::2] = rgb[1::2, 1::2, 2]
    return out


def write_dng(path, codes, black, white, neutral):
    """codes: H x W uint16 Bayer RGGB sensor codes (black level included)."""
    neutral = np.asarray(neutral, float)
    color_matrix = np.diag(neutral) @ XYZ_TO_SRGB
    tags = [
        (271, 's', 0, 'cdrf', True),                 # Make
        (272, 's', 0, 'synthetic capture', True),    # Model
        (33421, 'H', 2, (2, 2), True),               # CFARepeatPatternDim
        (33422, 'B', 4, (0, 1, 1, 2), True),         # CFAPattern: R G / G B
        (50706, 'B', 4, (1, 4, 0, 0), True),         # DNGVersion
        (50707, 'B', 4, (1, 1, 0, 0), True),         # DNGBackwardVersion
        (50708, 's', 0, 'cdrf synthetic capture', True),  # UniqueCameraModel
        (50710, 'B', 3, (0, 1, 2), True),            # CFAPlaneColor
        (50711, 'H', 1, 1, True),                    # CFALayout: rectangular
        (50713, 'H', 2, (1, 1), True),               # BlackLevelRepeatDim
        (50714, 'I', 1, int(black), True),           # BlackLevel
        (50717, 'I', 1, int(white), True),           # WhiteLevel
        (50721, '2i', 9, _rationals(color_matrix.ravel(), True), True),  # ColorMatrix1
        (50728, '2I', 3, _rationals(neutral), True),  # AsShotNeutral
        (50778, 'H', 1, 21, True),                   # CalibrationIlluminant1: D65
    ]
    tifffile.imwrite(path, np.ascontiguousarray(codes, np.uint16), photometric=32803,
                     subfiletype=0, extratags=tags, metadata=None)


def fixture(path):
    """32 x 24 sensor: block (bx, by) has linear sRGB (0.05 (bx + 1), (by + 1) / 16, 0.3); the block
    at (3, 2) is clipped. Neutral (0.5, 1.0, 0.7), black 512, white 16383."""
    black, white, neutral = 512, 16383, np.array([0.5, 1.0, 0.7])
    bx, by = np.meshgrid(np.arange(16), np.arange(12))
    srgb = np.stack([0.05 * (bx + 1), (by + 1) / 16.0, np.full(bx.shape, 0.3)], -1)
    camera = srgb * neutral
    full = np.repeat(np.repeat(camera, 2, 0), 2, 1)
    codes = np.round(black + full * (white - black)).clip(0, white)
    codes[4:6, 6:8] = white
    write_dng(path, mosaic_rggb(codes).astype(np.uint16), black, white, neutral)


if __name__ == '__main__':
    fixture(sys.argv[1])
