"""Color conversions. Linear RGB means Rec. 709 primaries with a linear transfer (Mitsuba's
``rgb`` variants); sRGB means the same primaries with the sRGB transfer function (IEC 61966-2-1)."""

import warnings

import numpy as np

with warnings.catch_warnings():  # colour-science warns about optional SciPy/Matplotlib features
    warnings.simplefilter("ignore")
    import colour

REC709_LUMINANCE = (0.2126, 0.7152, 0.0722)
"""Rec. 709 luminance weights of linear R, G, B, the project's one copy; numpy and torch code
turn them into an array of their own dtype and device."""


def srgb_to_linear(values: np.ndarray) -> np.ndarray:
    """Decode sRGB-encoded values in [0, 1] to linear values in [0, 1]."""
    return np.asarray(colour.models.eotf_sRGB(np.clip(values, 0.0, 1.0)), dtype=np.float32)


def linear_to_srgb(values: np.ndarray) -> np.ndarray:
    """Encode linear values (clipped to [0, 1]) with the sRGB transfer function."""
    return np.asarray(colour.models.eotf_inverse_sRGB(np.clip(values, 0.0, 1.0)), dtype=np.float32)


def luminance(rgb: np.ndarray) -> np.ndarray | np.floating:
    """Rec. 709 relative luminance of linear RGB, over the last axis."""
    return np.asarray(rgb, dtype=np.float32) @ np.asarray(REC709_LUMINANCE, dtype=np.float32)


def to_png_bytes(linear_rgb: np.ndarray) -> np.ndarray:
    """Linear RGB in [0, 1] to 8-bit sRGB, as a uint8 array for PNG writing."""
    return np.round(linear_to_srgb(linear_rgb) * 255.0).astype(np.uint8)


def normal_to_png_bytes(normal: np.ndarray) -> np.ndarray:
    """Unit normals (..., 3) encoded (n + 1) / 2 as 8-bit values (no transfer function), as a
    uint8 array for PNG writing."""
    return np.round((np.clip(normal, -1.0, 1.0) + 1.0) / 2.0 * 255.0).astype(np.uint8)
