"""Random view directions of the camera (docs/conventions.md: unit vectors from the surface
toward the camera, z > 0)."""

import numpy as np


def random_view(rng: np.random.Generator, max_angle_deg: float) -> np.ndarray:
    """Unit view direction, uniform in solid angle within ``max_angle_deg`` of +z."""
    cos_max = np.cos(np.radians(max_angle_deg))
    cos_t = 1 - rng.random() * (1 - cos_max)
    phi = 2 * np.pi * rng.random()
    sin_t = np.sqrt(max(0.0, 1 - cos_t * cos_t))
    return np.array([sin_t * np.cos(phi), sin_t * np.sin(phi), cos_t])
