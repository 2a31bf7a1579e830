"""HDR light probes: loading, validation, orientation and white balance.

A probe is an equirectangular (latitude-longitude) image of linear RGB radiance, W = 2 H.
World frame (docs/conventions.md): the sample plane is z = 0 and +z is up. Following Mitsuba's
envmap, pixel row i samples the polar angle theta_i = pi i / (H - 1) from the zenith (row 0 at
the zenith, the last row at the nadir) and column j the azimuth phi_j = -2 pi (j + 0.5) / W,
measured from +x and growing clockwise seen from above (the usual "seen from inside" panorama
orientation); radiance between samples is interpolated bilinearly, periodically in phi. A
probe rotated by psi degrees is turned counter-clockwise about +z: world = Rz(psi) * direction.

White balance (the paper's Equation 2): each channel is scaled so that the irradiance on the
upward-facing sample plane equals pi. The irradiance is then color-neutral, and a white
Lambertian plane (albedo 1) reflects a radiance of exactly 1 in every channel.
"""

import logging
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from render.common.errors import InputError, require_file, require_folder
from render.common.images import HDR_SUFFIXES, read_image

log = logging.getLogger(__name__)

# Negative pixels (ringing from resampling) are clamped to zero while the negative energy stays
# below this fraction of the positive energy; beyond it the file is rejected as corrupt.
MAX_NEGATIVE_ENERGY_FRACTION = 0.01


@dataclass(frozen=True)
class Probe:
    """A validated, white-balanced probe."""

    name: str
    """File stem, used in dataset provenance."""
    path: Path
    radiance: np.ndarray
    """(H, 2H, 3) float32 linear RGB, white-balanced so the plane irradiance is pi per channel."""
    white_balance: np.ndarray
    """(3,) per-channel factors that were applied to the file's radiance."""


def find_probes(folder: str | Path) -> list[Path]:
    """Sorted probe files (``.exr``, ``.hdr``) directly in ``folder``."""
    folder = require_folder(folder, "probe folder")
    files = sorted(p for p in folder.iterdir() if p.suffix.lower() in HDR_SUFFIXES)
    if not files:
        raise InputError(folder, "no probes (.exr or .hdr files) in this folder")
    return files


def load_probe(path: str | Path) -> Probe:
    """Read, validate and white-balance one probe file."""
    path = require_file(path, "probe")
    if path.suffix.lower() not in HDR_SUFFIXES:
        raise InputError(path, "a probe must be an HDR image (.exr or .hdr)")
    radiance = read_image(path)
    height, width, channels = radiance.shape
    if channels != 3:
        raise InputError(path, "grayscale probe: an RGB probe is needed for white balance")
    if width != 2 * height:
        raise InputError(path, f"not a 2:1 equirectangular probe ({width}x{height} pixels)")
    bad = ~np.isfinite(radiance)
    if bad.any():
        raise InputError(path, f"{int(bad.any(-1).sum())} pixels are NaN or Inf")
    radiance = _clamp_negative(path, radiance)
    irradiance = plane_irradiance(radiance)
    if not (irradiance > 0).all():
        raise InputError(path, f"no light above the horizon in some channel "
                               f"(irradiance {irradiance})")
    factors = (np.pi / irradiance).astype(np.float32)
    return Probe(path.stem, path, radiance * factors, factors)


def _clamp_negative(path, radiance):
    negative = radiance < 0
    if not negative.any():
        return radiance
    fraction = -radiance[negative].sum() / max(radiance[~negative].sum(), 1e-30)
    if fraction > MAX_NEGATIVE_ENERGY_FRACTION:
        raise InputError(path, f"negative radiance holds {fraction:.1%} of the energy")
    log.warning("%s: clamped %d slightly negative pixel values to zero", path,
                int(negative.sum()))
    return np.maximum(radiance, 0.0)


def latitude_weights(height: int, profile: Callable[[np.ndarray], np.ndarray],
                     steps_per_row: int = 64) -> np.ndarray:
    """Weights (H,) that integrate a probe's bilinear interpolant over the upper hemisphere.

    Row i's weight is the integral over theta in [0, pi/2] of its linear "tent" (1 at
    theta_i, 0 at the neighbouring rows) times ``profile(theta)``; with profile = sin this is
    the solid angle per unit azimuth a row stands for. Midpoint rule, ``steps_per_row`` steps.
    """
    steps = steps_per_row * height
    theta = (np.arange(steps) + 0.5) * (np.pi / 2 / steps)  # midpoints in [0, pi/2]
    row = theta * (height - 1) / np.pi
    below = np.floor(row)
    frac = row - below
    weight = profile(theta) * (np.pi / 2 / steps)
    band = np.zeros(height)
    np.add.at(band, below.astype(int), weight * (1 - frac))
    np.add.at(band, np.minimum(below + 1, height - 1).astype(int), weight * frac)
    return band


def plane_irradiance(radiance: np.ndarray) -> np.ndarray:
    """Irradiance on the upward plane, (3,): the integral of L cos(theta) over the upper
    hemisphere, with L interpolated bilinearly between samples as in the module docstring.
    Linear interpolation keeps each row's mean along phi, so only the latitude weights need
    integrating.
    """
    height, width = radiance.shape[:2]
    band = latitude_weights(height, lambda theta: np.cos(theta) * np.sin(theta))
    row_sums = radiance.astype(np.float64).sum(axis=1) * (2 * np.pi / width)  # (H, 3)
    return band @ row_sums


def tilted(radiance: np.ndarray, tilt_deg: float, azimuth_deg: float) -> np.ndarray:
    """``radiance`` (H, 2H, 3) of a probe turned by ``tilt_deg`` about the horizontal axis at
    azimuth ``azimuth_deg`` (degrees; the axis (cos a, sin a, 0), turned right-handedly), so
    that the probe's zenith moves to a direction ``tilt_deg`` from +z (a low sun can come
    overhead). Resampled from the probe's bilinear interpolant (module docstring) at the new
    samples' directions; not white-balanced again (load_probe and the torch renderer's
    ProbeBank balance what they are given). The zenith row, one direction, takes the value at
    one azimuth."""
    height, width = radiance.shape[:2]
    axis = np.radians(azimuth_deg)
    turn = Rotation.from_rotvec(np.radians(tilt_deg) * np.array([np.cos(axis), np.sin(axis), 0.0]))
    source = turn.inv().apply(pixel_directions(height, width).reshape(-1, 3)).reshape(
        height, width, 3)  # where each new sample's light came from
    theta = np.arccos(np.clip(source[..., 2], -1.0, 1.0))
    phi = np.arctan2(source[..., 1], source[..., 0])
    row = theta * (height - 1) / np.pi
    col = np.mod(-phi * width / (2 * np.pi) - 0.5, width)
    r0 = np.minimum(np.floor(row).astype(int), height - 2)
    c0 = np.floor(col).astype(int) % width
    fr, fc = (row - r0)[..., None], (col - np.floor(col))[..., None]
    c1 = (c0 + 1) % width
    top = radiance[r0, c0] * (1 - fc) + radiance[r0, c1] * fc
    bottom = radiance[r0 + 1, c0] * (1 - fc) + radiance[r0 + 1, c1] * fc
    return (top * (1 - fr) + bottom * fr).astype(radiance.dtype)


def pixel_directions(height: int, width: int, rotation_deg: float = 0.0) -> np.ndarray:
    """World directions (H, W, 3) of the probe's samples when rotated by ``rotation_deg``."""
    theta = np.pi * np.arange(height) / (height - 1)
    phi = -2 * np.pi * (np.arange(width) + 0.5) / width + np.radians(rotation_deg)
    sin_t = np.sin(theta)[:, None]
    return np.stack([sin_t * np.cos(phi), sin_t * np.sin(phi),
                     np.broadcast_to(np.cos(theta)[:, None], (height, width))], -1)
