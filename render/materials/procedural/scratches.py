"""Scratches: thin straight grooves, drawn and rasterized on the wrapped tile.

A scratch is a segment given by its centre (x, y), direction (degrees, counter-clockwise from
image right on screen), length and width, all in tile units (render.materials.procedural.noise
has the frame). Its profile is 1 on the segment's axis, falling to 0 at half its width from the
axis.
"""

import numpy as np

from render.materials.procedural.noise import smoothstep, wrapped_offset


def sample_scratches(rng: np.random.Generator, count: int, length_range: tuple[float, float],
                     width_range: tuple[float, float], angle_deg: float | None = None,
                     spread_deg: float = 180.0) -> list[dict]:
    """``count`` scratches; directions spread ``spread_deg`` around ``angle_deg`` (random if
    None). JSON-serializable."""
    centre_angle = rng.uniform(0, 180) if angle_deg is None else angle_deg
    return [{"x": float(rng.random()), "y": float(rng.random()),
             "angle_deg": float(centre_angle + rng.uniform(-0.5, 0.5) * spread_deg),
             "length": float(rng.uniform(*length_range)),
             "width": float(rng.uniform(*width_range)),
             "strength": float(rng.uniform(0.3, 1.0))} for _ in range(count)]


def scratch_profile(scratches: list[dict], x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Coverage in [0, 1] (the strongest scratch at each pixel) on positions (x, y).

    A scratch narrower than two pixels is drawn two pixels wide and proportionally fainter, so
    that it stays visible, with the same total coverage, at any resolution.
    """
    coverage = np.zeros(x.shape)
    pixel = 1.0 / x.shape[0]
    for scratch in scratches:
        angle = np.radians(scratch["angle_deg"])
        direction_x, direction_y = np.cos(angle), -np.sin(angle)  # y grows downward
        dx, dy = wrapped_offset(x, y, scratch["x"], scratch["y"])
        along = np.clip(dx * direction_x + dy * direction_y, -scratch["length"] / 2,
                        scratch["length"] / 2)
        distance = np.hypot(dx - along * direction_x, dy - along * direction_y)
        half_width = max(scratch["width"] / 2, pixel)
        profile = 1.0 - smoothstep(0.0, half_width, distance)
        strength = scratch["strength"] * min(1.0, scratch["width"] / (2 * half_width))
        coverage = np.maximum(coverage, strength * profile)
    return coverage
