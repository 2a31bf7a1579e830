"""What ``sa-estimate`` writes for its photos: a folder per photo and an HTML report.

Per photo (``write_photo_folder``), into ``OUT/<photo stem>/``:

    albedo.exr, albedo.png     relative diffuse albedo (mean about 0.5) over the whole photo at
                               its resolution (the longer side at most ``max_side``;
                               train.estimation.full_resolution): linear EXR, sRGB PNG
    normal.exr, normal.png     unit normals at the same resolution, encoded (n + 1) / 2, OpenGL
                               convention
    material.json              relative specular albedo and Ward roughness, photo, model: the
                               folder is a material folder that render-dataset reads
    scene.xml                  a Mitsuba scene rendering the estimate under the first probe
                               (render.mitsuba_reference.scene_file)
    material.glb               a plane (the photo's aspect) carrying the estimate as a glTF 2.0
                               metallic-roughness material (render.materials.gltf_file)
    photo.png                  the photo as read (linearized, then sRGB-encoded) at the maps' size
    relit-<probe>.png          the estimate relit under each probe (torch renderer,
                               auto-exposed, maps at the network's input scale)
    preview.png                photo | albedo | normals | relit under the first probe

and ``OUT/report.html`` (``write_report``), a page showing per photo the photo, the
full-resolution maps, the parameters with units and color spaces, and the relit images. Every
file appears under its final name only when whole (render.common.atomic_files).
"""

import html
from pathlib import Path
from urllib.parse import quote

import numpy as np
import torch
from PIL import Image

from render.common.atomic_files import atomic_path
from render.common.color import normal_to_png_bytes, to_png_bytes
from render.common.exposure import expose
from render.common.images import resize, write_png
from render.common.probes import Probe
from render.materials.gltf_file import write_gltf_file
from render.materials.reduced_svbrdf import ReducedSVBRDF, resample, write_material
from render.mitsuba_reference.scene_file import write_scene_file
from render.torch_renderer.renderer import ProbeBank, render


def write_photo_folder(folder: Path, svbrdf: ReducedSVBRDF, linear_photo: np.ndarray,
                       metadata: dict, short_side: int, probes: list[Probe], bank: ProbeBank,
                       probe_paths: tuple) -> list[str]:
    """Write the estimate ``svbrdf`` of the (H, W, 3) linear ``linear_photo`` into ``folder``
    (the module docstring's files; ``metadata`` goes into material.json, ``probes[0]`` lights
    the Mitsuba scene, ``bank`` holds ``probes`` for the relit images, named after
    ``probe_paths``); returns the relit files' names."""
    write_material(folder, svbrdf, metadata)
    write_scene_file(folder, svbrdf, probes[0])
    write_gltf_file(folder / "material.glb", svbrdf)
    return write_pictures(folder, linear_photo, svbrdf, short_side, bank, probe_paths)


def write_pictures(folder: Path, linear_photo: np.ndarray, svbrdf: ReducedSVBRDF,
                   short_side: int, bank: ProbeBank, probe_paths: tuple) -> list[str]:
    """photo.png and the PNG maps at the maps' size, relit-<probe>.png per probe and
    preview.png at ``short_side`` (the network's input scale); returns the relit files'
    names."""
    height, width = svbrdf.albedo.shape[:2]
    write_png(folder / "photo.png", np.clip(resize(linear_photo, height, width), 0.0, 1.0))
    write_png(folder / "albedo.png", svbrdf.albedo)
    with atomic_path(folder / "normal.png") as tmp:
        Image.fromarray(normal_to_png_bytes(svbrdf.normal)).save(tmp, "PNG")
    small = resample(svbrdf, short_side) if short_side < min(height, width) else svbrdf
    height, width = small.albedo.shape[:2]
    count = len(probe_paths)
    maps = [torch.as_tensor(a.transpose(2, 0, 1))[None].expand(count, -1, -1, -1)
            for a in (small.albedo, small.normal)]
    relit = expose(render(maps[0], maps[1],
                          torch.as_tensor(small.specular)[None].expand(count, -1),
                          torch.full((count,), small.roughness), bank, list(range(count))))
    names = []
    for image, probe_path in zip(relit, probe_paths):
        names.append(f"relit-{Path(probe_path).stem}.png")
        write_png(folder / names[-1], np.clip(image.numpy().transpose(1, 2, 0), 0.0, 1.0))
    panels = [to_png_bytes(np.clip(resize(linear_photo, height, width), 0.0, 1.0)),
              to_png_bytes(small.albedo), normal_to_png_bytes(small.normal),
              to_png_bytes(relit[0].numpy().transpose(1, 2, 0))]
    with atomic_path(folder / "preview.png") as tmp:
        Image.fromarray(np.concatenate(panels, axis=1)).save(tmp, "PNG")
    return names


def write_report(path: Path, reports: list[dict]) -> None:
    """An HTML page: per photo, the photo, the full-resolution maps, the parameters with units
    and color spaces, and the relit images; every image has alt text."""
    sections = "".join(report_section(report) for report in reports)
    page = ("<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\">"
            "<title>sa-estimate</title><style>body{font-family:sans-serif;margin:2em}"
            "figure{display:inline-block;max-width:360px;margin:0 1em 1em 0;vertical-align:top}"
            "img{max-width:360px;height:auto;border:1px solid #ccc}</style></head><body>"
            "<h1>Estimates</h1><p>Reduced SVBRDF (diffuse albedo and normals per pixel, one Ward "
            "specular lobe) estimated from each photo. Albedos are relative: scaled so that the "
            "diffuse albedo averages about 0.5 (the photo's exposure is unknown).</p>"
            f"{sections}</body></html>\n")
    with atomic_path(path) as tmp:
        tmp.write_text(page)


def report_section(report: dict) -> str:
    name = html.escape(Path(report["photo"]).name)
    folder = quote(Path(report["out"]).name)
    width, height = report["map_size"]

    def figure(src, alt, caption):
        return (f"<figure><a href=\"{src}\"><img src=\"{src}\" alt=\"{html.escape(alt)}\">"
                f"</a><figcaption>{caption}</figcaption></figure>")

    relit = "".join(figure(f"{folder}/{quote(file)}",
                           f"{name}: the estimate relit under probe "
                           f"{file[len('relit-'):-len('.png')]}",
                           f"relit under {html.escape(file[len('relit-'):-len('.png')])}")
                    for file in report["relit"])
    specular = " ".join(f"{v:.4f}" for v in report["specular_albedo"])
    network = html.escape(Path(report["model"]).name)
    # a report written before the fixed lobe existed has no "lobe": its network read the lobe
    lobe = ("fixed (the estimate for a material of unknown kind)"
            if report.get("lobe") == "fixed" else "read by the network")
    return (f"<h2>{name}</h2>"
            + figure(f"{folder}/photo.png", f"{name}: the photo", "photo")
            + figure(f"{folder}/albedo.png", f"{name}: estimated relative diffuse albedo, "
                     f"{width}x{height}", f"diffuse albedo, {width}x{height} px, sRGB PNG "
                     "(linear in albedo.exr)")
            + figure(f"{folder}/normal.png", f"{name}: estimated normals, {width}x{height}",
                     f"normals, {width}x{height} px, (n + 1) / 2, OpenGL convention")
            + f"<table><tr><th>relative specular albedo (linear RGB, unitless)</th>"
              f"<td>{specular}</td></tr><tr><th>Ward roughness &alpha; (unitless, slope "
              f"RMS)</th><td>{report['roughness']:.4f}</td></tr><tr><th>specular lobe</th>"
              f"<td>{lobe}</td></tr><tr><th>network</th>"
              f"<td>{network}</td></tr><tr><th>network time</th>"
              f"<td>{report['network_ms']} ms at input size, {report['full_resolution_ms']} "
              f"ms for the full-resolution maps</td></tr></table>"
            + f"<div>{relit}</div>")
