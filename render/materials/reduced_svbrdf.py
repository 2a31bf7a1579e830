"""Material folders to the paper's reduced SVBRDF.

A material folder holds texture maps in metallic-roughness form (the form users have), found
by name (``render.materials.map_names``) or named in an optional ``material.json`` (keys
below). The conversion to the reduced Ward model is documented in docs/conventions.md:

    rho_d(x)  = max(C(x) (1 - m(x)), MIN_DIFFUSE_ALBEDO)       per pixel, linear RGB
    rho_s     = mean_x [0.04 (1 - m(x)) + C(x) m(x)]           homogeneous, linear RGB
    alpha     = clamp(mean_x r(x)^2, ALPHA_RANGE)              homogeneous Ward roughness

with C the base color (sRGB-decoded unless it is an EXR or declared linear), m the metalness
(default 0) and r the perceptual roughness (default 0.5). Normals are tangent-space unit
vectors, x right, y up in the image, z out of the surface (OpenGL convention); DirectX maps
(``*_dx`` names or ``"normal_convention": "directx"``) have their y flipped. A missing normal
map means a flat surface, (0, 0, 1). Images whose names say no role are reported and ignored,
silently where material.json names the albedo map (a folder that says which files are maps,
such as sa-estimate's, with its pictures beside them).

``material.json`` keys (all optional):
    albedo, normal, roughness, metallic, arm, glossiness: a file name in the folder (or null to
        ignore an auto-detected file); roughness and metallic may also be numbers.
    specular_albedo: number or [r, g, b], the Ward rho_s directly (overrides the conversion).
    ward_roughness: number, the Ward alpha directly (overrides the conversion).
    normal_convention: "opengl" or "directx".   albedo_color_space: "srgb" or "linear".
    class: material class name (wood, plastic, metal, ...).   metadata: any JSON object.
"""

import json
import logging
import os
import shutil
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from render.common.atomic_files import write_json
from render.common.color import srgb_to_linear
from render.common.errors import InputError, require_folder
from render.common.images import IMAGE_SUFFIXES, is_hdr, read_image, resize, write_exr
from render.materials.map_names import is_directx_normal, map_role

log = logging.getLogger(__name__)

MIN_DIFFUSE_ALBEDO = 0.01
"""No real material is perfectly black; the floor also keeps the relative normalization finite."""
DIELECTRIC_F0 = 0.04
DEFAULT_ROUGHNESS = 0.5
ALPHA_RANGE = (0.02, 1.0)
MIN_NORMAL_Z = 0.05
MAP_ROLES = ("albedo", "normal", "roughness", "metallic", "arm", "glossiness")
JSON_KEYS = set(MAP_ROLES) | {"specular_albedo", "ward_roughness", "normal_convention",
                              "albedo_color_space", "class", "metadata"}


@dataclass(frozen=True)
class ReducedSVBRDF:
    """Per-pixel diffuse albedo and normal; homogeneous Ward specular albedo and roughness."""

    name: str
    albedo: np.ndarray
    """(H, W, 3) float32 linear RGB diffuse albedo (absolute, before relative normalization)."""
    normal: np.ndarray
    """(H, W, 3) float32 unit tangent-space normals, z > 0."""
    specular: np.ndarray
    """(3,) float32 linear RGB Ward specular albedo rho_s."""
    roughness: float
    """Ward alpha, in ALPHA_RANGE."""
    sources: dict = field(default_factory=dict)
    """Where each quantity came from (file names or 'default ...'), for provenance."""
    material_class: str | None = None


def find_materials(folder: str | Path) -> list[Path]:
    """Sorted material sub-folders of ``folder``."""
    folder = require_folder(folder, "folder of material folders")
    subfolders = sorted(p for p in folder.iterdir() if p.is_dir() and not p.name.startswith("."))
    if not subfolders:
        raise InputError(folder, "no material sub-folders (one folder per material is expected)")
    return subfolders


def load_material(folder: str | Path) -> ReducedSVBRDF:
    """Read one material folder and convert it to a ReducedSVBRDF."""
    folder = Path(folder)
    spec = _read_material_json(folder)
    files = _assign_maps(folder, spec)
    maps = {role: read_image(path) for role, path in files.items()}
    _check_sizes(files, maps)
    sources = {role: path.name for role, path in files.items()}

    base = maps["albedo"] if maps["albedo"].shape[2] == 3 else np.repeat(maps["albedo"], 3, 2)
    color_space = spec.get("albedo_color_space", "linear" if is_hdr(files["albedo"]) else "srgb")
    if color_space not in ("srgb", "linear"):
        raise InputError(folder / "material.json", "albedo_color_space must be 'srgb' or 'linear'")
    if color_space == "srgb":
        base = srgb_to_linear(base)
    shape = base.shape[:2]
    metallic = _scalar_map(folder, spec, files, maps, "metallic", arm_channel=2, default=0.0,
                           shape=shape, sources=sources)
    roughness = _scalar_map(folder, spec, files, maps, "roughness", arm_channel=1,
                            default=DEFAULT_ROUGHNESS, shape=shape, sources=sources)
    if "glossiness" in files and "roughness" not in files and "arm" not in files:
        roughness = 1.0 - maps["glossiness"][..., 0]

    albedo = np.maximum(base * (1.0 - metallic[..., None]), MIN_DIFFUSE_ALBEDO)
    specular = (DIELECTRIC_F0 * (1.0 - metallic[..., None])
                + base * metallic[..., None]).mean((0, 1))
    alpha = float(np.mean(roughness.astype(np.float64) ** 2))
    if "specular_albedo" in spec:
        specular = _specular_override(folder, spec["specular_albedo"])
        sources["specular"] = "material.json specular_albedo"
    if "ward_roughness" in spec:
        alpha = _number(folder, "ward_roughness", spec["ward_roughness"])
        sources["roughness"] = "material.json ward_roughness"
    alpha = float(np.clip(alpha, *ALPHA_RANGE))

    if "normal" in files:
        directx = spec.get("normal_convention", "directx" if is_directx_normal(files["normal"])
                           else "opengl") == "directx"
        normal = decode_normal_map(files["normal"], maps["normal"], directx)
    else:
        normal = np.zeros(shape + (3,), np.float32)
        normal[..., 2] = 1.0
        sources["normal"] = "default flat (0, 0, 1)"
    return ReducedSVBRDF(folder.name, albedo.astype(np.float32), normal,
                         np.asarray(specular, np.float32), alpha, sources, spec.get("class"))


def _read_material_json(folder):
    if not folder.is_dir():
        raise InputError(folder, "material folder not found")
    path = folder / "material.json"
    if not path.exists():
        return {}
    try:
        spec = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as error:
        raise InputError(path, f"invalid JSON ({error})") from None
    if not isinstance(spec, dict):
        raise InputError(path, "must hold a JSON object")
    unknown = sorted(set(spec) - JSON_KEYS)
    if unknown:
        raise InputError(path, f"unknown keys {unknown} (known: {sorted(JSON_KEYS)})")
    return spec


def _assign_maps(folder, spec):
    """Map role -> file, from material.json first, then from file names."""
    images = sorted(p for p in folder.iterdir()
                    if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES)
    if not images and not any(isinstance(spec.get(r), str) for r in MAP_ROLES):
        raise InputError(folder, "empty material folder (no image files)")
    files, unrecognized = {}, []
    for path in images:
        role = map_role(path)
        if role is None:
            unrecognized.append(path)
        elif role != "ignored" and role not in spec:
            if role in files:
                raise InputError(path, f"second {role} map (also {files[role].name}); "
                                       "name the right one in material.json")
            files[role] = path
    if "albedo" not in files and "albedo" not in spec and len(unrecognized) == 1:
        files["albedo"] = unrecognized.pop()
    if "albedo" not in spec:  # where material.json names the maps, other images are no maps
        for path in unrecognized:
            log.warning("%s: unrecognized map name, ignored", path)
    for role in MAP_ROLES:
        value = spec.get(role)
        if isinstance(value, str):
            files[role] = folder / value
            if not files[role].is_file():
                raise InputError(files[role], f"named as the {role} map in material.json "
                                              "but not found")
    if "albedo" not in files:
        raise InputError(folder, "no albedo map recognized (expected a name ending in _albedo, "
                                 "_col, _color, _basecolor, _diffuse, or material.json 'albedo')")
    return files


def _check_sizes(files, maps):
    reference = maps["albedo"].shape[:2]
    for role, pixels in maps.items():
        if pixels.shape[:2] != reference:
            raise InputError(files[role], f"{role} map is {pixels.shape[1]}x{pixels.shape[0]} "
                                          f"but the albedo map {files['albedo'].name} is "
                                          f"{reference[1]}x{reference[0]}")


def _scalar_map(folder, spec, files, maps, role, arm_channel, default, shape, sources):
    """A scalar map in [0, 1] from its own file, the packed ARM map, a number, or a default."""
    value = spec.get(role)
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        sources[role] = f"material.json {role}={value}"
        return np.full(shape, float(value), np.float32)
    if value is not None and not isinstance(value, str):
        raise InputError(folder / "material.json", f"'{role}' must be a file name or a number")
    if role in files:
        return np.clip(maps[role][..., 0], 0.0, 1.0)
    if "arm" in files:
        arm = maps["arm"]
        if arm.shape[2] != 3:
            raise InputError(files["arm"], "packed ARM map must have 3 channels")
        sources[role] = f"{files['arm'].name} channel {'RGB'[arm_channel]}"
        return np.clip(arm[..., arm_channel], 0.0, 1.0)
    sources[role] = f"default {default}"
    return np.full(shape, default, np.float32)


def _number(folder, key, value):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        raise InputError(folder / "material.json", f"'{key}' must be a finite number")
    return float(value)


def _specular_override(folder, value):
    values = value if isinstance(value, list) else [value] * 3
    if len(values) != 3:
        raise InputError(folder / "material.json", "'specular_albedo' needs 1 or 3 numbers")
    return np.array([_number(folder, "specular_albedo", v) for v in values], np.float32)


def decode_normal_map(path: str | Path, pixels: np.ndarray, directx: bool) -> np.ndarray:
    """Encoded normal map (values in [0, 1], or raw [-1, 1] in float files) to unit normals."""
    if pixels.shape[2] != 3:
        raise InputError(path, f"normal map must be RGB (got {pixels.shape[2]} channel)")
    normal = pixels * 2.0 - 1.0 if pixels.min() >= 0.0 else pixels.copy()
    if directx:
        normal[..., 1] *= -1.0
    normal[..., 2] = np.maximum(normal[..., 2], MIN_NORMAL_Z)
    return (normal / np.linalg.norm(normal, axis=2, keepdims=True)).astype(np.float32)


def resample(svbrdf: ReducedSVBRDF, short_side: int) -> ReducedSVBRDF:
    """The same material with maps resampled so that their shorter side is ``short_side``.

    Downsampling averages pixel areas (box filter), upsampling interpolates bilinearly;
    normals are renormalized afterwards.
    """
    height, width = svbrdf.albedo.shape[:2]
    scale = short_side / min(height, width)
    size = (max(1, round(height * scale)), max(1, round(width * scale)))
    if size == (height, width):
        return svbrdf
    normal = resize(svbrdf.normal, *size)
    normal /= np.linalg.norm(normal, axis=2, keepdims=True)
    return ReducedSVBRDF(svbrdf.name, resize(svbrdf.albedo, *size), normal, svbrdf.specular,
                         svbrdf.roughness, svbrdf.sources, svbrdf.material_class)


def write_material(folder: str | Path, svbrdf: ReducedSVBRDF, metadata: dict) -> None:
    """Write ``svbrdf`` as a material folder that ``load_material`` reads back unchanged.

    ``albedo.exr`` holds the linear diffuse albedo, ``normal.exr`` the normals encoded as
    (n + 1) / 2 (OpenGL convention), and ``material.json`` the homogeneous ``specular_albedo``
    and ``ward_roughness``, the class and ``metadata``. The folder is assembled under a
    temporary name and renamed into place, so it exists complete or not at all; an existing
    folder is never overwritten.
    """
    folder = Path(folder)
    if folder.exists():
        raise InputError(folder, "already exists; not overwritten")
    tmp = folder.with_name(f".{folder.name}.tmp{os.getpid()}")
    shutil.rmtree(tmp, ignore_errors=True)
    try:
        tmp.mkdir(parents=True)
        write_exr(tmp / "albedo.exr", svbrdf.albedo)
        write_exr(tmp / "normal.exr", (svbrdf.normal + 1.0) / 2.0)
        write_json(tmp / "material.json", {
            "albedo": "albedo.exr", "normal": "normal.exr", "albedo_color_space": "linear",
            "normal_convention": "opengl",
            "specular_albedo": [float(v) for v in svbrdf.specular],
            "ward_roughness": float(svbrdf.roughness), "class": svbrdf.material_class,
            "metadata": metadata})
        os.replace(tmp, folder)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
