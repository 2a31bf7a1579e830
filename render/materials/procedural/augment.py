"""More material sets of a class from the few real ones: crop, turn, recolor, blend.

One augmented set is made from one real set of the class (two when blending):
1. ``crop``: a square of ``fraction`` of the source's shorter side at (``top``, ``left``)
   (fractions of the height and width), resampled to the output size. A crop of the whole
   tile keeps a tileable source tileable; smaller crops are not tileable.
2. ``quarter_turns``: counter-clockwise turns; the normals turn with the picture.
3. ``recolor``: the diffuse albedo's Oklab lightness and chroma scaled and its hue turned, within
   the class's range (CLASS_RECOLOR); metals also take the F0 of another measured metal, and
   their diffuse film takes its hue (only the hue: a real "metal" set without a metalness map
   was reduced as a dielectric, with rho_s 0.04, and its bright albedo becomes a dark film,
   ``film`` (2 to 8%) times it, like the generated metals' film).
4. ``blend``: a second set (cropped and turned the same way) shown through a tileable noise
   mask; normals are blended and renormalized, and the homogeneous specular albedo and
   roughness are the mask-weighted means (as docs/conventions.md reduces per-pixel values).

Every choice is drawn in ``sample_augmentation`` and recorded, so ``augment(parameters,
sources, size)`` is a pure function of the source sets.
"""

from dataclasses import replace

import numpy as np

from render.common.color import luminance
from render.common.labels import rotate_quarter_turns
from render.materials.map_names import tokens
from render.materials.procedural.noise import gaussian_noise, smoothstep
from render.materials.procedural.palette import SURFACE_METALS, measured, vary_color
from render.materials.reduced_svbrdf import ALPHA_RANGE, MIN_DIFFUSE_ALBEDO, ReducedSVBRDF, resample

CLASS_NAME_TOKENS = {
    "wood": {"wood", "wooden", "oak", "walnut", "pine", "maple", "plank", "planks", "parquet"},
    "plastic": {"plastic", "acrylic", "vinyl", "pvc", "rubber"},
    "metal": {"metal", "aluminium", "aluminum", "steel", "iron", "copper", "brass", "bronze",
              "gold", "silver", "chrome", "zinc", "tin"},
}
"""Name tokens that mark a real set's class when its material.json gives none."""

CLASS_RECOLOR = {"wood": {"lightness": (0.7, 1.3), "chroma": (0.6, 1.2), "hue_deg": 10.0},
                 "plastic": {"lightness": (0.7, 1.3), "chroma": (0.5, 1.5), "hue_deg": 180.0},
                 "metal": {"lightness": (0.8, 1.2), "chroma": (0.8, 1.2), "hue_deg": 5.0}}
"""Ranges of the diffuse recoloring: woods stay brown, plastics may take any hue."""

DIELECTRIC_LOOKING_F0 = 0.2
"""A "metal" set whose rho_s luminance is below this had no metalness map: it was reduced as a
dielectric, its base color is in its albedo, and it becomes a dark film of ``film`` times it."""


def material_class_of(svbrdf: ReducedSVBRDF) -> str | None:
    """The class of a real set: its material.json ``class``, else a class word in its name."""
    if svbrdf.material_class:
        return svbrdf.material_class
    words = set(tokens(svbrdf.name))
    for material_class, names in CLASS_NAME_TOKENS.items():
        if words & names:
            return material_class
    return None


def sample_augmentation(rng: np.random.Generator, material_class: str, source_names: list[str],
                        blend_probability: float = 0.35) -> dict:
    """Draw one augmentation of ``material_class`` from the named sources (a JSON dict)."""
    recolor = CLASS_RECOLOR[material_class]
    parameters = {
        "source": str(rng.choice(source_names)),
        "crop": {"fraction": float(rng.choice([1.0, rng.uniform(0.5, 1.0)])),
                 "top": float(rng.random()), "left": float(rng.random())},
        "quarter_turns": int(rng.integers(4)),
        "recolor": {"lightness": float(rng.uniform(*recolor["lightness"])),
                    "chroma": float(rng.uniform(*recolor["chroma"])),
                    "hue_deg": float(rng.uniform(-1, 1) * recolor["hue_deg"])},
    }
    if material_class == "metal":
        parameters["recolor"]["metal"] = str(rng.choice(SURFACE_METALS))
        parameters["recolor"]["film"] = float(rng.uniform(0.02, 0.08))
    if len(source_names) > 1 and rng.random() < blend_probability:
        others = [name for name in source_names if name != parameters["source"]]
        parameters["blend"] = {"source": str(rng.choice(others)),
                               "seed": int(rng.integers(2**31)),
                               "frequency": float(rng.uniform(1.5, 6.0)),
                               "threshold": float(rng.uniform(-0.5, 0.5))}
    return parameters


def augment(parameters: dict, sources: dict[str, ReducedSVBRDF], size: int, name: str,
            material_class: str) -> ReducedSVBRDF:
    """The augmented ReducedSVBRDF; ``sources`` maps source names to loaded real sets."""
    albedo, normal = _crop_and_turn(sources[parameters["source"]], parameters, size)
    specular = sources[parameters["source"]].specular.astype(np.float64)
    alpha = sources[parameters["source"]].roughness
    if "blend" in parameters:
        blend = parameters["blend"]
        other = sources[blend["source"]]
        other_albedo, other_normal = _crop_and_turn(other, parameters, size)
        noise = gaussian_noise(size, blend["seed"], 1, blend["frequency"], slope=1.0)
        mask = smoothstep(blend["threshold"] - 0.3, blend["threshold"] + 0.3, noise)[..., None]
        albedo = albedo * (1 - mask) + other_albedo * mask
        normal = normal * (1 - mask) + other_normal * mask
        normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
        coverage = float(mask.mean())
        specular = specular * (1 - coverage) + other.specular * coverage
        alpha = alpha * (1 - coverage) + other.roughness * coverage
    recolor = parameters["recolor"]
    albedo = vary_color(albedo, recolor["lightness"], recolor["chroma"], recolor["hue_deg"])
    if "metal" in recolor:
        new_f0 = np.asarray(measured(recolor["metal"]).specular)
        if luminance(specular) < DIELECTRIC_LOOKING_F0:  # the metal's color is in its albedo
            albedo = albedo * recolor["film"]
        tint = _chroma(new_f0) / _chroma(specular)  # the hue of the new metal, same brightness
        albedo, specular = albedo * tint, new_f0
    albedo = np.clip(albedo, MIN_DIFFUSE_ALBEDO, 1.0).astype(np.float32)
    used = [parameters["source"]]
    if "blend" in parameters:
        used.append(parameters["blend"]["source"])
    return ReducedSVBRDF(name, albedo, normal.astype(np.float32),
                         np.asarray(specular, np.float32), float(np.clip(alpha, *ALPHA_RANGE)),
                         {"augmented from": used}, material_class)


def _chroma(rgb):
    """``rgb`` divided by its luminance: its color without its brightness."""
    rgb = np.maximum(np.asarray(rgb, np.float64), 1e-4)
    return rgb / float(luminance(rgb))


def _crop_and_turn(svbrdf, parameters, size):
    """Crop (fractions of the source), resample to size x size, then turn."""
    height, width = svbrdf.albedo.shape[:2]
    crop = parameters["crop"]
    side = max(1, round(crop["fraction"] * min(height, width)))
    top = round(crop["top"] * (height - side))
    left = round(crop["left"] * (width - side))
    window = (slice(top, top + side), slice(left, left + side))
    cropped = resample(replace(svbrdf, albedo=svbrdf.albedo[window],
                               normal=svbrdf.normal[window]), size)
    _, albedo, normal = rotate_quarter_turns(cropped.albedo, cropped.albedo, cropped.normal,
                                             parameters["quarter_turns"])
    return albedo.astype(np.float64), normal.astype(np.float64)
