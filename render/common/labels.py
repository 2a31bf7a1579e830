"""Crops, quarter-turn rotations and the paper's relative-albedo labels of one rendered sample.

Rotations are by multiples of 90 degrees (``np.rot90``, counter-clockwise as displayed): they
are exact, need no resampling, and keep image and labels aligned pixel for pixel. Turning the
picture turns the tangent-space normals with it: (x, y) -> (-y, x) per quarter turn, x right
and y up in the image.
"""

import numpy as np


def rotate_quarter_turns(image: np.ndarray, albedo: np.ndarray, normal: np.ndarray,
                         turns: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rotate (H, W, C) maps by ``turns`` x 90 degrees counter-clockwise; normals turn too."""
    turns %= 4
    image, albedo, normal = (np.rot90(a, turns) for a in (image, albedo, normal))
    x, y = normal[..., 0], normal[..., 1]
    for _ in range(turns):
        x, y = -y, x
    normal = np.stack([x, y, normal[..., 2]], -1)
    return np.ascontiguousarray(image), np.ascontiguousarray(albedo), normal


def relative_labels(albedo: np.ndarray,
                    specular: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The paper's relative albedos: s = 2 mean(albedo) over pixels and channels.

    Returns (albedo / s, log(specular / s)); mean(albedo / s) is 0.5.
    """
    scale = 2.0 * float(np.mean(albedo))
    return albedo / scale, np.log(np.asarray(specular, np.float64) / scale)
