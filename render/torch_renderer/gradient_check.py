"""``check-renderer --gradients``: the torch renderer's gradients against Mitsuba's own
automatic differentiation of the same scenes.

The cases are check-renderer's (``make_cases``: every material with every probe). Per case, a
fixed random linear functional of the exposed image, phi = sum(W * expose(image)) with W
standard normal (seeded by the case). Its derivative with respect to the HDR image,
G = d phi / d image, is taken by torch at the Mitsuba render and then held fixed, so that both
renderers differentiate the same functional sum(G * image) with respect to the diffuse albedo
map, the normal map (its raw stored values), the specular albedo and the roughness:
- torch: ``render()`` and autograd, in float64;
- Mitsuba: the mean of ``passes`` independent estimates at ``spp`` samples per pixel
  (``PlanarSampleRenderer.gradients``, unbiased); their spread is the reference's own Monte
  Carlo error.

Per case and parameter (t: torch's gradient, m: Mitsuba's mean, both flattened):
- ``error``: |t - m| / |m|, the relative L2 error;
- ``cosine``: t.m / (|t| |m|) (for a scalar, its sign agreement);
- ``noise``: the standard error of m relative to |m|, sqrt(sum of variances / passes) / |m|;
- ``agrees``: error <= tolerance + 3 noise.
"""

import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from render.common.atomic_files import write_json
from render.common.errors import require_output_folder
from render.common.exposure import expose
from render.torch_renderer.check import (DEFAULT_ROUGHNESS, CheckConfig, case_svbrdf,
                                         load_cases)
from render.torch_renderer.renderer import ProbeBank, render

PARAMETERS = ("albedo", "normal", "specular", "roughness")
DEFAULT_TOLERANCE = 0.02


def image_cotangent(reference: np.ndarray, seed: int) -> np.ndarray:
    """G = d sum(W * expose(image)) / d image at the HDR ``reference`` (H, W, 3), W standard
    normal drawn from ``seed``: (H, W, 3) float64."""
    weights = np.random.default_rng(seed).normal(size=reference.shape)
    image = torch.tensor(reference, dtype=torch.float64).permute(2, 0, 1)[None]
    image.requires_grad_(True)
    functional = (expose(image) * torch.tensor(weights).permute(2, 0, 1)[None]).sum()
    functional.backward()
    return image.grad[0].permute(1, 2, 0).numpy()


def torch_gradients(albedo: np.ndarray, normal: np.ndarray, specular: np.ndarray,
                    roughness: float, bank: ProbeBank, probe: int, rotation_deg: float,
                    view: np.ndarray, cotangent: np.ndarray) -> dict[str, np.ndarray]:
    """Gradients of sum(cotangent * render(...)) by torch autograd in float64, in the layout
    of ``PlanarSampleRenderer.gradients``."""
    def tensor(array):
        return torch.tensor(np.asarray(array, np.float64), requires_grad=True)

    inputs = dict(albedo=tensor(albedo), normal=tensor(normal), specular=tensor(specular),
                  roughness=tensor(roughness))
    image = render(inputs["albedo"].permute(2, 0, 1)[None], inputs["normal"].permute(2, 0, 1)[None],
                   inputs["specular"][None], inputs["roughness"].reshape(1), bank, [probe],
                   torch.tensor([rotation_deg], dtype=torch.float64),
                   torch.tensor(np.asarray(view, np.float64))[None])
    (image[0].permute(1, 2, 0) * torch.tensor(cotangent)).sum().backward()
    return {name: value.grad.numpy() for name, value in inputs.items()}


def agreement(ours: np.ndarray, estimates: Sequence[np.ndarray],
              tolerance: float) -> dict:
    """error, cosine, noise and agrees of one parameter's gradient (see the module
    docstring)."""
    samples = np.stack([np.ravel(e).astype(np.float64) for e in estimates])
    mean = samples.mean(0)
    t = np.ravel(ours).astype(np.float64)
    scale = max(float(np.linalg.norm(mean)), 1e-300)
    error = float(np.linalg.norm(t - mean)) / scale
    noise = float(np.sqrt(samples.var(0, ddof=1).sum() / len(samples))) / scale
    cosine = float(t @ mean) / max(float(np.linalg.norm(t)) * scale, 1e-300)
    return dict(error=error, cosine=cosine, noise=noise,
                agrees=bool(error <= tolerance + 3 * noise))


def compare_gradients(probes_dir: str | Path, svbrdfs_dir: str | Path, size: int = 16,
                      spp: int = 1024, passes: int = 8,
                      roughness: Sequence[float] = DEFAULT_ROUGHNESS,
                      max_view_angle: float = 0.0, seed: int = 0,
                      tolerance: float = DEFAULT_TOLERANCE, out: str | Path | None = None,
                      progress: bool = True) -> dict:
    """Both renderers' gradients on every case; the report (dict): per-case rows, and per
    parameter the worst error and whether every case agrees."""
    from render.mitsuba_reference.scene import PlanarSampleRenderer  # Mitsuba is needed here only

    probes, materials, maps, cases = load_cases(probes_dir, svbrdfs_dir, size, roughness,
                                                max_view_angle, seed)
    bank = ProbeBank([p.radiance for p in probes], dtype=torch.float64)
    mitsuba = PlanarSampleRenderer(spp=spp)
    rows = []
    started = time.perf_counter()
    for index, case in enumerate(tqdm(cases, desc="gradients", disable=not progress)):
        svbrdf = case_svbrdf(materials, maps, case)
        probe = probes[case.probe]
        reference = mitsuba.render(svbrdf, probe, case.rotation_deg, case.view, seed=index)
        cotangent = image_cotangent(reference, seed=index)
        estimates = [mitsuba.gradients(svbrdf, probe, case.rotation_deg, case.view, cotangent,
                                       seed=(index + 1) * 1000 + k) for k in range(passes)]
        ours = torch_gradients(svbrdf.albedo, svbrdf.normal, case.specular, case.roughness,
                               bank, case.probe, case.rotation_deg, case.view, cotangent)
        row = dict(material=svbrdf.name, probe=probe.name,
                   alpha=case.roughness, view=[round(float(v), 6) for v in case.view])
        for name in PARAMETERS:
            row[name] = agreement(ours[name], [e[name] for e in estimates], tolerance)
        rows.append(row)
    summary = {name: dict(worst_error=max(r[name]["error"] for r in rows),
                          worst_noise=max(r[name]["noise"] for r in rows),
                          min_cosine=min(r[name]["cosine"] for r in rows),
                          all_agree=all(r[name]["agrees"] for r in rows))
               for name in PARAMETERS}
    report = dict(size=size, spp=spp, passes=passes, tolerance=tolerance, cases=len(rows),
                  seconds=time.perf_counter() - started, summary=summary, rows=rows)
    if out is not None:
        write_json(Path(out) / "gradients.json", report)
    return report


def run(cfg: CheckConfig) -> dict:
    """``check-renderer --gradients``: ``compare_gradients`` on the cases of ``cfg``; its
    report."""
    if cfg.out is not None:
        require_output_folder(cfg.out)
    return compare_gradients(cfg.probes, cfg.svbrdfs, cfg.size, cfg.spp, cfg.passes,
                             cfg.roughness, cfg.max_view_angle, cfg.seed, cfg.tolerance,
                             cfg.out)
