"""Rendering a reduced SVBRDF under a probe with Mitsuba 3 (the reference path).

The scene is ``scenes/planar_sample.xml``; this module fills in its parameters. Output images
are HDR linear RGB radiance, (H, W, 3) float32, row 0 at the top, in texture space: pixel
(row, col) is the radiance leaving texel (row, col) toward the view direction.
"""

from __future__ import annotations

import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from render.common.images import write_exr
from render.common.package_data import SCENES, installed_file
from render.mitsuba_reference.loading import load_mitsuba

if TYPE_CHECKING:
    from render.common.probes import Probe

SCENE_FILE = installed_file(SCENES, "planar_sample.xml")
DEFAULT_SAMPLER = "multijitter"
EMITTER_ONLY_ROUGHNESS = 0.22
"""From this Ward alpha up, each sample takes two probe (emitter) samples and no BSDF sample;
below it, one of each, combined by multiple importance sampling. Broad lobes are integrated
best by sampling the probe (5 to 9 dB higher PSNR at equal time at alpha 0.23 to 0.35 under
sunny and studio probes); sharp lobes need BSDF samples (emitter-only: 18 dB at alpha 0.02).
At alpha 0.2 the two are close (a studio probe's lamps: MIS 1.3 dB better; the sun: probe
samples 5.5 dB better), so the switch sits just below the broadest shared set that needs it
(godot_rock, 0.228: 49.9 -> 58.3 dB). Both are unbiased. Measured in docs/performance.md."""
# Lanes (pixels x samples) per Mitsuba render call; larger images are rendered in strips.
LANE_BUDGET = {"llvm": 1 << 22, "cuda": 1 << 25}

# Mitsuba's envmap frame has +y up, u = 0 at local -z and u = 0.25 at +x. This maps it to our
# world (+z up, azimuth -2 pi u from +x), see render/common/probes.py.
_ENVMAP_TO_WORLD = np.array([[0, 0, -1, 0], [-1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 1]], float)
_CAMERA_DISTANCE = 10.0


def probe_to_world(rotation_deg: float) -> np.ndarray:
    """4x4 to_world matrix of Mitsuba's envmap for a probe rotated by ``rotation_deg`` about +z."""
    c, s = np.cos(np.radians(rotation_deg)), np.sin(np.radians(rotation_deg))
    rotation = np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
    return rotation @ _ENVMAP_TO_WORLD


def camera_to_world(view: np.ndarray | Sequence[float]) -> np.ndarray:
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


def matrix_text(matrix: np.ndarray) -> str:
    return " ".join(repr(float(v)) for v in np.asarray(matrix).ravel())


class PlanarSampleRenderer:
    """Mitsuba renderer of planar samples.

    Speed (docs/performance.md): a scene is built once per image size, sample count and probe
    size, and each further render only updates its parameters (textures, probe, transforms,
    specular albedo and roughness, all opaque to Dr.Jit), so Dr.Jit reuses the compiled kernels
    instead of tracing and compiling new ones for every image. Images larger than the lane
    budget are rendered in strips of rows (the film's crop window, updated the same way); the
    result is the same as a scene built from scratch for every strip.
    """

    def __init__(self, variant: str = "llvm_ad_rgb", spp: int = 1024,
                 sampler: str = DEFAULT_SAMPLER, threads: int | None = None):
        self.mi = load_mitsuba(variant, threads)
        self.spp = spp
        self.sampler = sampler
        self.lane_budget = LANE_BUDGET["cuda" if variant.startswith("cuda") else "llvm"]
        self._scenes = {}

    def _scene(self, svbrdf, probe, rotation_deg, view, spp, rows_per_strip):
        """(scene, its traversed parameters) for images of ``svbrdf``'s size at ``spp``,
        ``probe``'s size, strips of ``rows_per_strip`` rows and the sample split of its
        roughness (EMITTER_ONLY_ROUGHNESS); built on first use from these inputs (so that a
        parameter that render() failed to update would show)."""
        height, width = svbrdf.albedo.shape[:2]
        emitter_only = svbrdf.roughness >= EMITTER_ONLY_ROUGHNESS
        key = (height, width, probe.radiance.shape, spp, rows_per_strip, emitter_only)
        if key not in self._scenes:
            # The scene file names its textures and probe by path; Mitsuba reads them while
            # it loads the scene, so the files live only that long.
            with tempfile.TemporaryDirectory(prefix="sa-svbrdf-scene-") as folder:
                files = {}
                for name, pixels in (("albedo", svbrdf.albedo), ("normal", svbrdf.normal),
                                     ("probe", probe.radiance)):
                    files[name] = str(Path(folder) / f"{name}.exr")
                    write_exr(files[name], pixels)
                scene = self.mi.load_file(
                    str(SCENE_FILE), spp=str(spp), sampler=self.sampler, width=str(width),
                    height=str(height), crop_x="0", crop_y="0", crop_width=str(width),
                    crop_height=str(rows_per_strip), aspect=repr(height / width),
                    camera=matrix_text(camera_to_world(view)),
                    probe_to_world=matrix_text(probe_to_world(rotation_deg)),
                    specular=" ".join(repr(float(v)) for v in svbrdf.specular),
                    alpha=repr(float(svbrdf.roughness)),
                    emitter_samples="2" if emitter_only else "1",
                    bsdf_samples="0" if emitter_only else "1", **files)
            self._scenes[key] = (scene, self.mi.traverse(scene))
        return self._scenes[key]

    def _prepare(self, svbrdf, probe, rotation_deg, view, spp):
        """The scene of these inputs with every parameter set; (scene, parameters, rows per
        strip)."""
        mi = self.mi
        height, width = svbrdf.albedo.shape[:2]
        rows_per_strip = min(height, max(1, self.lane_budget // (width * spp)))
        scene, params = self._scene(svbrdf, probe, rotation_deg, view, spp, rows_per_strip)
        # Texture rows are flipped: Mitsuba's texture v grows with world +y, while our row 0
        # is the top (largest y) of the sample.
        params["sample.bsdf.albedo.data"] = mi.TensorXf(np.ascontiguousarray(
            np.flipud(svbrdf.albedo), np.float32))
        params["sample.bsdf.normal.data"] = mi.TensorXf(np.ascontiguousarray(
            np.flipud(svbrdf.normal), np.float32))
        params["sample.bsdf.specular"] = mi.Color3f(*(float(v) for v in svbrdf.specular))
        params["sample.bsdf.alpha"] = mi.Float(float(svbrdf.roughness))
        # The envmap stores its image with one wrapped column on each side.
        radiance = np.asarray(probe.radiance, np.float32)
        params["probe.data"] = mi.TensorXf(np.ascontiguousarray(np.concatenate(
            [radiance[:, -1:], radiance, radiance[:, :1]], axis=1)))
        params["probe.to_world"] = mi.AffineTransform4f(probe_to_world(rotation_deg))
        params["sensor.to_world"] = mi.AffineTransform4f(camera_to_world(view))
        return scene, params, rows_per_strip

    def _strips(self, params, height, width, rows_per_strip):
        """Select each strip of rows in turn on the film: yields (strip index, first row,
        rows)."""
        mi = self.mi
        for index, top in enumerate(range(0, height, rows_per_strip)):
            rows = min(rows_per_strip, height - top)
            params["sensor.film.crop_offset"] = mi.ScalarPoint2u(0, top)
            params["sensor.film.crop_size"] = mi.ScalarVector2u(width, rows)
            params.update()
            yield index, top, rows

    def render(self, svbrdf: Any, probe: Probe, rotation_deg: float = 0.0,
               view: np.ndarray | Sequence[float] = (0.0, 0.0, 1.0), seed: int = 0,
               spp: int | None = None) -> np.ndarray:
        """HDR radiance (H, W, 3) of ``svbrdf`` under ``probe`` rotated by ``rotation_deg``."""
        spp = spp or self.spp
        height, width = svbrdf.albedo.shape[:2]
        scene, params, rows_per_strip = self._prepare(svbrdf, probe, rotation_deg, view, spp)
        strips = []
        for index, _, _ in self._strips(params, height, width, rows_per_strip):
            strips.append(np.array(self.mi.render(scene, seed=_strip_seed(seed, index)),
                                   dtype=np.float32))
        return np.concatenate(strips, axis=0)

    def gradients(self, svbrdf: Any, probe: Probe, rotation_deg: float,
                  view: np.ndarray | Sequence[float], cotangent: np.ndarray, seed: int = 0,
                  spp: int | None = None) -> dict[str, np.ndarray]:
        """Gradients of sum(cotangent * image) by Mitsuba's automatic differentiation, where
        image is the HDR render of ``render()`` at this seed and ``cotangent`` an (H, W, 3)
        array: ``albedo`` and ``normal`` (H, W, 3, our row order; the normal's raw stored
        values, normalized by the BSDF), ``specular`` (3,) and ``roughness`` (a float, per unit
        of Ward alpha). One unbiased Monte Carlo estimate (ward_bsdf.py says why)."""
        import drjit as dr  # imported by load_mitsuba in __init__ already

        mi = self.mi
        spp = spp or self.spp
        height, width = svbrdf.albedo.shape[:2]
        scene, params, rows_per_strip = self._prepare(svbrdf, probe, rotation_deg, view, spp)
        keys = dict(albedo="sample.bsdf.albedo.data", normal="sample.bsdf.normal.data",
                    specular="sample.bsdf.specular", roughness="sample.bsdf.alpha")
        for key in keys.values():
            dr.enable_grad(params[key])
        try:
            for index, top, rows in self._strips(params, height, width, rows_per_strip):
                image = mi.render(scene, params, seed=_strip_seed(seed, index))
                weights = mi.TensorXf(np.ascontiguousarray(cotangent[top:top + rows],
                                                           np.float32))
                dr.backward(dr.sum(image * weights, axis=None))
            grads = {name: np.array(dr.grad(params[key])) for name, key in keys.items()}
        finally:
            for key in keys.values():
                dr.disable_grad(params[key])
        return dict(albedo=np.flipud(grads["albedo"]).copy(),
                    normal=np.flipud(grads["normal"]).copy(),
                    specular=grads["specular"].reshape(3),
                    roughness=float(grads["roughness"].reshape(-1)[0]))


def _strip_seed(seed: int, index: int) -> int:
    return (seed * 1_000_003 + index) % (1 << 32)
