"""``check-renderer``: the torch renderer against converged Mitsuba renders of the same cases.

A case is a (material, probe, roughness, specular albedo, rotation, view). Every material is
paired with every probe; each pair gets one roughness from the list (cycling, so that every
probe and every material meets every roughness when there are enough of them), alternately the
material's own specular albedo and the brightest one among the materials, a random rotation
and a random view within ``max_view_angle``. Errors, per case:
- PSNR (dB) between the two auto-exposed, clamped [0, 1] images (each exposed on its own, as
  the pipeline does), the number the threshold applies to;
- relative MSE of the HDR images before exposure, sum (t - m)^2 / sum m^2.
With ``confirm_spp``, a case below the threshold is judged against a second Mitsuba render at
that sample count instead (so that the reference's own noise cannot fail the check). The
gradients' comparison is gradient_check.py.
"""

import dataclasses
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from render.common.atomic_files import write_json
from render.common.errors import require_output_folder
from render.common.exposure import expose_numpy
from render.common.images import write_png
from render.common.probes import Probe, find_probes, load_probe
from render.common.views import random_view
from render.materials.reduced_svbrdf import (ReducedSVBRDF, find_materials, load_material,
                                             resample)
from render.torch_renderer.renderer import ProbeBank, render

DEFAULT_ROUGHNESS = (0.02, 0.05, 0.1, 0.2, 0.5, 1.0)


@dataclass(frozen=True)
class CheckConfig:
    probes: str
    """Folder of HDR probes (.exr, .hdr); every probe is paired with every material, one case
    per pair."""
    svbrdfs: str
    """Folder of material folders."""
    size: int = 64
    """Image size (px): each material resampled to it on its short side, its central square."""
    spp: int = 1024
    """Mitsuba samples per pixel (the reference must be converged)."""
    roughness: tuple = DEFAULT_ROUGHNESS
    """Ward alphas the cases cycle through."""
    max_view_angle: float = 0.0
    """Largest random view tilt from +z (degrees)."""
    seed: int = 0
    """Seed of the rotations and views."""
    threshold: float = 40.0
    """The check fails when any case's PSNR (dB) is below this."""
    confirm_spp: int = 0
    """Cases below the threshold are rendered again by Mitsuba at this many samples per pixel
    and judged against that reference (so that the reference's own noise cannot fail the
    check); 0: not."""
    out: str | None = None
    """Folder for side-by-side images (Mitsuba | torch | 10x difference) and report.json, or
    with ``gradients`` for gradients.json."""
    gradients: bool = False
    """Compare gradients with Mitsuba's automatic differentiation instead of images
    (render/torch_renderer/gradient_check.py); ``spp`` is then per pass."""
    passes: int = 8
    """With ``gradients``: independent Mitsuba estimates per case (their spread is the
    reference's noise)."""
    tolerance: float = 0.02
    """With ``gradients``: the check fails where a relative L2 error exceeds this plus 3 times
    the reference's relative noise."""


@dataclass
class Case:
    material: int
    probe: int
    roughness: float
    specular: np.ndarray
    rotation_deg: float
    view: np.ndarray


def make_cases(materials: list[ReducedSVBRDF], probes: list[Probe],
               roughness_values: Sequence[float], max_view_angle: float,
               seed: int) -> list[Case]:
    """One case per (material, probe) pair, see the module docstring."""
    rng = np.random.default_rng(seed)
    brightest = max((m.specular for m in materials), key=lambda s: float(np.mean(s)))
    cases = []
    for i in range(len(materials)):
        for j in range(len(probes)):
            own = (i + j) % 2 == 0
            cases.append(Case(i, j, roughness_values[(i + j) % len(roughness_values)],
                              materials[i].specular if own else brightest,
                              float(rng.uniform(0, 360)), random_view(rng, max_view_angle)))
    return cases


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    """PSNR in dB of two images in [0, 1]."""
    return float(10 * np.log10(1.0 / max(float(np.mean((a - b) ** 2)), 1e-20)))


def square_crop(svbrdf: ReducedSVBRDF, size: int) -> tuple[np.ndarray, np.ndarray]:
    """The material resampled to ``size`` on its short side and cut to its central square."""
    svbrdf = resample(svbrdf, size)
    top = (svbrdf.albedo.shape[0] - size) // 2
    left = (svbrdf.albedo.shape[1] - size) // 2
    window = (slice(top, top + size), slice(left, left + size))
    return svbrdf.albedo[window], svbrdf.normal[window]


def load_cases(probes_dir: str | Path, svbrdfs_dir: str | Path, size: int,
               roughness: Sequence[float], max_view_angle: float, seed: int
               ) -> tuple[list[Probe], list[ReducedSVBRDF],
                          list[tuple[np.ndarray, np.ndarray]], list[Case]]:
    """The probes, the materials, their (albedo, normal) maps cut to ``size`` (square_crop)
    and the cases (make_cases) of a check."""
    probes = [load_probe(p) for p in find_probes(probes_dir)]
    materials = [load_material(m) for m in find_materials(svbrdfs_dir)]
    maps = [square_crop(m, size) for m in materials]
    return probes, materials, maps, make_cases(materials, probes, list(roughness),
                                               max_view_angle, seed)


def case_svbrdf(materials: list[ReducedSVBRDF], maps: list[tuple[np.ndarray, np.ndarray]],
                case: Case) -> ReducedSVBRDF:
    """The material of ``case`` with its cut maps and the case's specular albedo and
    roughness."""
    albedo, normal = maps[case.material]
    return dataclasses.replace(materials[case.material], albedo=albedo, normal=normal,
                               specular=case.specular, roughness=case.roughness)


def render_torch(cases: list[Case], bank: ProbeBank,
                 maps: list[tuple[np.ndarray, np.ndarray]], batch_size: int) -> np.ndarray:
    """Torch renders of all cases, (N, H, W, 3) float32, in batches."""
    images = []
    for start in range(0, len(cases), batch_size):
        chunk = cases[start:start + batch_size]
        albedo = torch.from_numpy(np.stack([maps[c.material][0] for c in chunk]))
        normal = torch.from_numpy(np.stack([maps[c.material][1] for c in chunk]))
        hdr = render(albedo.permute(0, 3, 1, 2), normal.permute(0, 3, 1, 2),
                     torch.tensor(np.stack([c.specular for c in chunk]), dtype=torch.float32),
                     torch.tensor([c.roughness for c in chunk], dtype=torch.float32),
                     bank, torch.tensor([c.probe for c in chunk]),
                     torch.tensor([c.rotation_deg for c in chunk], dtype=torch.float32),
                     torch.tensor(np.stack([c.view for c in chunk]), dtype=torch.float32))
        images.append(hdr.permute(0, 2, 3, 1).numpy())
    return np.concatenate(images)


def compare(probes_dir: str | Path, svbrdfs_dir: str | Path, size: int = 64, spp: int = 1024,
            roughness: Sequence[float] = DEFAULT_ROUGHNESS, max_view_angle: float = 0.0,
            seed: int = 0, out: str | Path | None = None, batch_size: int = 16,
            progress: bool = True, threshold: float = 40.0, confirm_spp: int = 0) -> dict:
    """Render every case both ways; the report (dict) with per-case rows and the worst case.
    With ``confirm_spp``, the cases below ``threshold`` are judged against a reference at
    ``confirm_spp`` instead (each row's ``reference_spp`` says which)."""
    from render.mitsuba_reference.scene import PlanarSampleRenderer  # Mitsuba is needed here only

    probes, materials, maps, cases = load_cases(probes_dir, svbrdfs_dir, size, roughness,
                                                max_view_angle, seed)
    bank = ProbeBank([p.radiance for p in probes])

    started = time.perf_counter()
    torch_images = render_torch(cases, bank, maps, batch_size)
    torch_seconds = time.perf_counter() - started

    mitsuba = PlanarSampleRenderer(spp=spp)
    rows, mitsuba_seconds = [], 0.0
    for index, case in enumerate(tqdm(cases, desc="mitsuba", disable=not progress)):
        svbrdf = case_svbrdf(materials, maps, case)
        started = time.perf_counter()
        reference = mitsuba.render(svbrdf, probes[case.probe], case.rotation_deg, case.view,
                                   seed=index)
        mitsuba_seconds += time.perf_counter() - started
        ours = torch_images[index]
        exposed_ref, exposed_ours = expose_numpy(reference)[0], expose_numpy(ours)[0]
        reference_spp, score = spp, psnr(exposed_ours, exposed_ref)
        if confirm_spp and score < threshold:
            reference = mitsuba.render(svbrdf, probes[case.probe], case.rotation_deg,
                                       case.view, seed=index, spp=confirm_spp)
            exposed_ref, reference_spp = expose_numpy(reference)[0], confirm_spp
            score = psnr(exposed_ours, exposed_ref)
        row = dict(material=svbrdf.name, probe=probes[case.probe].name,
                   roughness=case.roughness, specular=[float(v) for v in case.specular],
                   rotation_deg=round(case.rotation_deg, 3),
                   view=[round(float(v), 6) for v in case.view], reference_spp=reference_spp,
                   psnr_db=round(score, 3),
                   relative_mse=float(np.sum((ours - reference) ** 2) / np.sum(reference ** 2)))
        rows.append(row)
        if out is not None:
            difference = np.clip(np.abs(exposed_ours - exposed_ref) * 10, 0, 1)
            write_png(Path(out) / f"{index:04d}_{svbrdf.name}_{row['probe']}.png",
                      np.concatenate([exposed_ref, exposed_ours, difference], axis=1))
    worst = min(rows, key=lambda r: r["psnr_db"])
    report = dict(size=size, spp=spp, cases=len(rows), worst=worst,
                  mean_psnr_db=float(np.mean([r["psnr_db"] for r in rows])),
                  max_relative_mse=max(r["relative_mse"] for r in rows),
                  torch_seconds=torch_seconds, mitsuba_seconds=mitsuba_seconds, rows=rows)
    if out is not None:
        write_json(Path(out) / "report.json", report)
    return report


def run(cfg: CheckConfig) -> dict:
    """``check-renderer`` without ``gradients``: ``compare`` on the cases of ``cfg``; its
    report (with ``gradients``: gradient_check.run)."""
    if cfg.out is not None:
        require_output_folder(cfg.out)
    return compare(cfg.probes, cfg.svbrdfs, cfg.size, cfg.spp, cfg.roughness,
                   cfg.max_view_angle, cfg.seed, cfg.out, threshold=cfg.threshold,
                   confirm_spp=cfg.confirm_spp)
