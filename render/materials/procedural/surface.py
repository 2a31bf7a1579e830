"""A generated surface in full, and its reduction to the paper's model.

Generators describe a material per pixel: diffuse albedo, height, normal-incidence reflectance F0
and perceptual roughness r. The reduction is the one ``render.materials.reduced_svbrdf``
applies to real texture sets (docs/conventions.md): the diffuse albedo and the normals stay per
pixel, and ``rho_s = mean F0`` and ``alpha = clamp(mean r^2)`` become homogeneous, as in the
paper.

Heights are in tile units (the tile is 1 x 1), so a height field describes the same surface at
any resolution. Normals are unit tangent-space vectors, x toward image right, y toward image up,
z out of the surface.
"""

from dataclasses import dataclass

import numpy as np

from render.materials.reduced_svbrdf import ALPHA_RANGE, MIN_DIFFUSE_ALBEDO, ReducedSVBRDF


@dataclass(frozen=True)
class Surface:
    albedo: np.ndarray
    """(S, S, 3) linear RGB diffuse albedo."""
    height: np.ndarray
    """(S, S) height in tile units."""
    f0: np.ndarray
    """(3,) or (S, S, 3) linear RGB normal-incidence reflectance."""
    roughness: np.ndarray | float
    """Perceptual roughness r, a number or (S, S)."""

    def reduced(self, name: str, material_class: str | None, sources: dict) -> ReducedSVBRDF:
        """The ReducedSVBRDF of this surface."""
        f0 = np.asarray(self.f0, np.float64).reshape(-1, 3).mean(0)
        alpha = float(np.clip(np.mean(np.asarray(self.roughness, np.float64) ** 2), *ALPHA_RANGE))
        albedo = np.clip(self.albedo, MIN_DIFFUSE_ALBEDO, 1.0).astype(np.float32)
        return ReducedSVBRDF(name, albedo, height_to_normal(self.height),
                             f0.astype(np.float32), alpha, sources, material_class)


def height_to_normal(height: np.ndarray) -> np.ndarray:
    """Unit normals (S, S, 3) float32 of the surface z = height(x, y).

    Slopes are central differences that wrap around the tile's edges, so a tileable height gives
    a tileable normal map. With rows growing downward, the upward slope is minus the row slope.
    """
    size = height.shape[0]
    height = height.astype(np.float64)
    slope_x = (np.roll(height, -1, axis=1) - np.roll(height, 1, axis=1)) * (size / 2.0)
    slope_down = (np.roll(height, -1, axis=0) - np.roll(height, 1, axis=0)) * (size / 2.0)
    normal = np.stack([-slope_x, slope_down, np.ones_like(height)], -1)
    return (normal / np.linalg.norm(normal, axis=-1, keepdims=True)).astype(np.float32)
