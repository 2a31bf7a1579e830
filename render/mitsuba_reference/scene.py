"""Rendering a reduced SVBRDF under a probe with Mitsuba 3 (the reference path).

The scene is ``scenes/planar_sample.xml``; this module fills in its parameters. Output images
are HDR linear RGB radiance, (H, W, 3) float32, row 0 at the top, in texture space: pixel
(row, col) is the radiance leaving texel (row, col) toward the view direction.
"""

import hashlib
import tempfile
from pathlib import Path

import numpy as np

from render.common.images import write_exr
from render.mitsuba_reference.loading import load_mitsuba

SCENE_FILE = Path(__file__).resolve().parents[2] / "scenes" / "planar_sample.xml"
DEFAULT_SAMPLER = "multijitter"
# Lanes (pixels x samples) per Mitsuba render call; larger images are rendered in strips.
LANE_BUDGET = {"llvm": 1 << 22, "cuda": 1 << 25}

# Mitsuba's envmap frame has +y up, u = 0 at local -z and u = 0.25 at +x. This maps it to our
# world (+z up, azimuth -2 pi u from +x), see render/common/probes.py.
_ENVMAP_TO_WORLD = np.array([[0, 0, -1, 0], [-1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 1]], float)
_CAMERA_DISTANCE = 10.0


def probe_to_world(rotation_deg):
    """4x4 to_world matrix of Mitsuba's envmap for a probe rotated by ``rotation_deg`` about +z."""
    c, s = np.cos(np.radians(rotation_deg)), np.sin(np.radians(rotation_deg))
    rotation = np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
    return rotation @ _ENVMAP_TO_WORLD


def camera_to_world(view):
    """Orthographic camera looking along -view whose film maps one pixel to one texel.

    Mitsuba's camera-local x points to the image's left, y up and z forward. Local (x, y, 0)
    goes to the plane point (-x, y, 0) shifted by distance * view, and local z to -view, so
    every ray hits the plane exactly at its pixel's texel, for any view direction.
    """
    view = np.asarray(view, float) / np.linalg.norm(view)
    if view[2] <= 0:
        raise ValueError(f"view direction {view} is not above the sample plane")
    matrix = np.eye(4)
    matrix[:3, 0] = [-1, 0, 0]
    matrix[:3, 1] = [0, 1, 0]
    matrix[:3, 2] = -view
    matrix[:3, 3] = _CAMERA_DISTANCE * view
    return matrix


def matrix_text(matrix):
    return " ".join(repr(float(v)) for v in np.asarray(matrix).ravel())


class PlanarSampleRenderer:
    """Mitsuba renderer of planar samples; reuses the texture files it has already written."""

    def __init__(self, variant="llvm_ad_rgb", spp=1024, sampler=DEFAULT_SAMPLER, threads=None):
        self.mi = load_mitsuba(variant, threads)
        self.spp = spp
        self.sampler = sampler
        self.lane_budget = LANE_BUDGET["cuda" if variant.startswith("cuda") else "llvm"]
        self._workdir = tempfile.TemporaryDirectory(prefix="sa-svbrdf-scene-")
        self._written = {}

    def _exr_file(self, pixels):
        """Write ``pixels`` once (keyed by content) as an EXR file for Mitsuba; its path."""
        pixels = np.ascontiguousarray(pixels, np.float32)
        key = (pixels.shape, hashlib.sha1(pixels.data).hexdigest())
        if key not in self._written:
            path = Path(self._workdir.name) / f"{len(self._written)}.exr"
            write_exr(path, pixels)
            self._written[key] = path
        return str(self._written[key])

    def render(self, svbrdf, probe, rotation_deg=0.0, view=(0.0, 0.0, 1.0), seed=0, spp=None):
        """HDR radiance (H, W, 3) of ``svbrdf`` under ``probe`` rotated by ``rotation_deg``."""
        spp = spp or self.spp
        height, width = svbrdf.albedo.shape[:2]
        params = dict(
            spp=str(spp), sampler=self.sampler, width=str(width), height=str(height),
            crop_x="0", crop_width=str(width), aspect=repr(height / width),
            camera=matrix_text(camera_to_world(view)),
            probe_to_world=matrix_text(probe_to_world(rotation_deg)),
            probe=self._exr_file(probe.radiance),
            # Texture rows are flipped: Mitsuba's texture v grows with world +y, while our
            # row 0 is the top (largest y) of the sample.
            albedo=self._exr_file(np.flipud(svbrdf.albedo)),
            normal=self._exr_file(np.flipud(svbrdf.normal)),
            specular=" ".join(repr(float(v)) for v in svbrdf.specular),
            alpha=repr(float(svbrdf.roughness)))
        rows_per_strip = max(1, self.lane_budget // (width * spp))
        strips = []
        for index, top in enumerate(range(0, height, rows_per_strip)):
            rows = min(rows_per_strip, height - top)
            scene = self.mi.load_file(str(SCENE_FILE), crop_y=str(top), crop_height=str(rows),
                                      **params)
            strip_seed = (seed * 1_000_003 + index) % (1 << 32)
            strips.append(np.array(self.mi.render(scene, seed=strip_seed), dtype=np.float32))
        return np.concatenate(strips, axis=0)
