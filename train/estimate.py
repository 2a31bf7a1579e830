"""``sa-estimate``: the reduced SVBRDF of photos, from a trained SVBRDF-net checkpoint.

For each photo (read by train.photos.read_photo: linearized, centre square, resized to the
network's input size) it writes a folder ``OUT/<photo stem>/`` holding:

    albedo.exr, albedo.png     relative diffuse albedo (mean 0.5): linear EXR, sRGB PNG
    normal.exr, normal.png     unit normals encoded (n + 1) / 2, OpenGL convention
    material.json              relative specular albedo and Ward roughness, photo, model: the
                               folder is a material folder that render-dataset reads
    scene.xml                  a Mitsuba scene rendering the estimate
                               (render.mitsuba_reference.scene_file)
    material.glb               a unit plane carrying the estimate as a glTF 2.0
                               metallic-roughness material (render.materials.gltf_file)
    preview.png                photo | albedo | normals | the estimate relit under ``probe``
                               (torch renderer, auto-exposed), a probe unrelated to the photo

and ``OUT/report.html``, a page of all the previews with the estimated parameters. The
command prints a JSON line per photo with the milliseconds the network took. Every photo is
read and checked before anything is written; an existing output folder is refused.
"""

import html
import time
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import quote

import numpy as np
import torch
from PIL import Image

from render.common.atomic_files import atomic_path
from render.common.color import normal_to_png_bytes, to_png_bytes
from render.common.errors import InputError, require_output_folder
from render.common.exposure import expose
from render.common.images import write_png
from render.common.probes import load_probe
from render.materials.gltf_file import write_gltf_file
from render.materials.reduced_svbrdf import ReducedSVBRDF, write_material
from render.mitsuba_reference.scene_file import write_scene_file
from render.torch_renderer.renderer import ProbeBank, render
from train.model_files import load_network
from train.photos import read_photo

REPO = Path(__file__).resolve().parent.parent
DEFAULT_PROBE = REPO / "probes" / "park.exr"


def estimate(net, photo):
    """(3, S, S) photo -> ReducedSVBRDF of relative quantities (name unset)."""
    with torch.no_grad():
        output = net(torch.as_tensor(photo)[None].to(next(net.parameters()).device))
    albedo = output["albedo"][0].cpu().numpy().transpose(1, 2, 0)
    normal = output["normal"][0].cpu().numpy().transpose(1, 2, 0)
    specular = np.exp(output["log_specular"][0].cpu().numpy())
    roughness = float(np.clip(np.exp(output["log_roughness"][0, 0].item()), 0.02, 1.0))
    return ReducedSVBRDF("", np.ascontiguousarray(albedo), np.ascontiguousarray(normal),
                         specular.astype(np.float32), roughness)


@dataclass(frozen=True)
class EstimateConfig:
    photos: tuple
    """Photo files (PNG, JPEG, TIFF, BMP, EXR, HDR), read by train.photos.read_photo."""
    model: str
    """A model file (.safetensors), an sa-train checkpoint (.pt) or a run folder (its newest
    checkpoint); train.model_files reads each without executing code."""
    out: str
    """Output folder: a folder per photo and report.html."""
    probe: str = str(DEFAULT_PROBE)
    """HDR probe of the relit preview and the Mitsuba scene."""
    device: str = "cpu"
    """torch device of the network (cpu, cuda); previews render on the CPU."""


def run(cfg):
    """Estimate the reduced SVBRDF of each photo of ``cfg`` and write the outputs; returns a
    report per photo (its output folder, network milliseconds and parameters)."""
    require_output_folder(cfg.out)
    net = load_network(cfg.model, torch.device(cfg.device))
    size = net.config.input_size
    inputs = [read_photo(path, size) for path in cfg.photos]
    stems = [Path(path).stem for path in cfg.photos]
    if len(set(stems)) != len(stems):
        raise InputError(cfg.photos[0], "two photos share a file name stem (output folders)")
    preview_probe = load_probe(cfg.probe)
    bank = ProbeBank([preview_probe.radiance])  # previews render on the CPU
    reports = []
    for path, photo, stem in zip(cfg.photos, inputs, stems):
        start = time.perf_counter()
        svbrdf = estimate(net, photo)
        milliseconds = 1000.0 * (time.perf_counter() - start)
        folder = Path(cfg.out) / stem
        write_material(folder, ReducedSVBRDF(stem, svbrdf.albedo, svbrdf.normal,
                                             svbrdf.specular, svbrdf.roughness),
                       {"photo": str(Path(path).resolve()), "model": str(Path(cfg.model))})
        _write_pictures(folder, photo, svbrdf, bank, preview_probe)
        reports.append({"photo": str(path), "out": str(folder), "model": str(cfg.model),
                        "network_ms": round(milliseconds, 1),
                        "specular_albedo": svbrdf.specular.tolist(),
                        "roughness": svbrdf.roughness})
    _write_report(Path(cfg.out) / "report.html", reports)
    return reports


def _write_report(path, reports):
    """An HTML page: each photo's preview (photo | albedo | normals | relit) and parameters."""
    rows = "".join(
        f"<h2>{html.escape(Path(r['photo']).name)}</h2>"
        f"<img src=\"{quote(Path(r['out']).name)}/preview.png\" width=\"1024\" "
        f"alt=\"{html.escape(Path(r['photo']).name)}: the photo, the estimated relative diffuse "
        f"albedo, the estimated normals, and the estimate relit under another probe\">"
        f"<p>relative specular albedo {' '.join(f'{v:.4f}' for v in r['specular_albedo'])}; "
        f"Ward roughness {r['roughness']:.4f}; network {r['network_ms']} ms</p>" for r in reports)
    page = ("<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>sa-estimate</title>"
            "</head><body><h1>Estimates</h1><p>Each row: photo | relative diffuse albedo | "
            f"normals | the estimate relit under another probe.</p>{rows}</body></html>\n")
    with atomic_path(path) as tmp:
        tmp.write_text(page)


def _write_pictures(folder, photo, svbrdf, bank, probe):
    write_png(folder / "albedo.png", svbrdf.albedo)
    with atomic_path(folder / "normal.png") as tmp:
        Image.fromarray(normal_to_png_bytes(svbrdf.normal)).save(tmp, "PNG")
    write_scene_file(folder, svbrdf, probe)
    write_gltf_file(folder / "material.glb", svbrdf)
    tensors = [torch.as_tensor(a.transpose(2, 0, 1))[None] for a in (svbrdf.albedo,
                                                                     svbrdf.normal)]
    relit = expose(render(tensors[0], tensors[1], torch.as_tensor(svbrdf.specular)[None],
                          torch.tensor([svbrdf.roughness]), bank, [0]))[0]
    panels = [to_png_bytes(photo.transpose(1, 2, 0)), to_png_bytes(svbrdf.albedo),
              normal_to_png_bytes(svbrdf.normal),
              to_png_bytes(relit.numpy().transpose(1, 2, 0))]
    with atomic_path(folder / "preview.png") as tmp:
        Image.fromarray(np.concatenate(panels, axis=1)).save(tmp, "PNG")

