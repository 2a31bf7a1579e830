"""Tileable noise fields for procedural materials.

Every field lives on the unit torus: the tile is the square [0, 1)^2, lengths are in tile units
and frequencies in cycles per tile, so a field and everything built from it wraps seamlessly at
the tile's edges. Arrays are (size, size), row 0 at the top; the position of pixel (row, col) is
``x = (col + 0.5) / size`` (toward image right), ``y = (row + 0.5) / size`` (toward image
*down*). Angles are counter-clockwise from image right as seen on screen, in degrees.

Fields are resolution independent: a field depends on its parameters and seed only, and
``size`` says where it is sampled. Gaussian noise is built by spectral synthesis with NumPy's FFT
(white noise filtered in the frequency domain, which is periodic by construction); cellular
(Worley) noise uses SciPy's periodic k-d tree.
"""

import numpy as np
from scipy.spatial import cKDTree


def pixel_positions(size: int) -> tuple[np.ndarray, np.ndarray]:
    """(x, y) of the pixel centres, each (size, size), in tile units (y grows downward)."""
    coordinate = (np.arange(size, dtype=np.float64) + 0.5) / size
    return np.meshgrid(coordinate, coordinate)


def gaussian_noise(size: int, seed: int, low: float, high: float, slope: float = 1.0,
                   stretch: float = 1.0, angle_deg: float = 0.0) -> np.ndarray:
    """Zero-mean, unit-variance tileable Gaussian noise.

    Its amplitude spectrum is ``rho^-slope`` on the band ``low <= rho <= high`` (cycles per tile)
    and zero elsewhere, with ``rho`` the frequency measured with the along-``angle_deg`` component
    multiplied by ``stretch``: ``stretch > 1`` gives streaks elongated along that direction
    (fibres, brushing). ``slope`` 1 is fractal (1/f) noise, 0 band-limited white noise.

    The noise is synthesized on the smallest grid that holds the band and Fourier-resampled to
    ``size``, so it is the same function at every size (frequencies above ``size / 2`` are
    dropped where the size cannot hold them).
    """
    if not 0 < low <= high:
        raise ValueError(f"noise band must satisfy 0 < low <= high (got {low}, {high})")
    grid = 2 * int(np.ceil(high)) + 2
    frequencies = np.fft.fftfreq(grid, 1.0 / grid)
    along, across = _rotated_frequencies(frequencies, angle_deg)
    rho = np.hypot(along * stretch, across)
    in_band = (rho >= low) & (rho <= high)
    amplitude = np.where(in_band, np.maximum(rho, 1e-9) ** -slope, 0.0)
    amplitude /= np.sqrt(np.mean(amplitude ** 2))  # unit variance of the filtered white noise
    white = np.random.default_rng(seed).standard_normal((grid, grid))
    spectrum = np.fft.fft2(white) * amplitude
    return _resample_spectrum(spectrum, grid, size)


def _rotated_frequencies(frequencies, angle_deg):
    """Frequency components along and across a direction, on the FFT grid (rows: y down)."""
    column_frequency = frequencies[None, :]
    row_frequency = frequencies[:, None]
    angle = np.radians(angle_deg)
    # On screen the direction is (cos a, sin a) with y up, i.e. (cos a, -sin a) with y down.
    along = column_frequency * np.cos(angle) - row_frequency * np.sin(angle)
    across = column_frequency * np.sin(angle) + row_frequency * np.cos(angle)
    return along, across


def _resample_spectrum(spectrum, grid, size):
    """The periodic function of a grid x grid spectrum, sampled at a size x size grid's pixel
    centres (frequencies the size cannot hold are dropped)."""
    frequencies = np.fft.fftfreq(grid, 1.0 / grid).astype(int)
    kept = np.flatnonzero(np.abs(frequencies) < size / 2)
    target = frequencies[kept] % size
    half_pixel = np.exp(1j * np.pi * frequencies[kept] / size)  # sample at (j + 0.5) / size
    resized = np.zeros((size, size), complex)
    resized[np.ix_(target, target)] = (spectrum[np.ix_(kept, kept)]
                                       * half_pixel[:, None] * half_pixel[None, :])
    return (np.fft.ifft2(resized).real * (size * size) / (grid * grid)).astype(np.float32)


def cellular(size: int, seed: int, count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Periodic Worley noise over ``count`` uniformly scattered feature points.

    Returns ``(f1, f2, cell)``: the distances (tile units) from each pixel to its nearest and
    second-nearest feature point across the tile's wrapped edges, and the index of the nearest.
    """
    points = np.random.default_rng(seed).random((count, 2))
    x, y = pixel_positions(size)
    tree = cKDTree(points, boxsize=1.0)
    distances, cells = tree.query(np.stack([x.ravel(), y.ravel()], -1), k=2)
    shape = (size, size)
    return (distances[:, 0].reshape(shape).astype(np.float32),
            distances[:, 1].reshape(shape).astype(np.float32), cells[:, 0].reshape(shape))


def wrapped_offset(x: np.ndarray, y: np.ndarray, centre_x: float,
                   centre_y: float) -> tuple[np.ndarray, np.ndarray]:
    """Offsets (dx, dy) from a point to pixels, by the shortest way across the wrapped tile."""
    dx = (x - centre_x + 0.5) % 1.0 - 0.5
    dy = (y - centre_y + 0.5) % 1.0 - 0.5
    return dx, dy


def smoothstep(edge0: float, edge1: float, value: np.ndarray) -> np.ndarray:
    """Hermite step from 0 at ``edge0`` to 1 at ``edge1``."""
    t = np.clip((value - edge0) / (edge1 - edge0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)
