"""Colors and reflectances of real materials, the ground truth the generators draw from.

- ``physically-based-materials.json`` (bundled beside this file; CC0, from the
  physically-based-api project by Anton Palmqvist, see CREDITS.md there): 86 measured materials
  with a linear RGB color, metalness, perceptual roughness and index of refraction. For metals
  the color is the normal-incidence reflectance F0; for dielectrics F0 follows from the index of
  refraction, ``((n - 1) / (n + 1))^2``, and the color is the diffuse albedo.
- ``WOOD_TONES``: the database has no wood, so wood colors come from the two real wood texture
  sets of the shared data (godot_texture_wood, materialx_wood): the mean linear albedo of the
  pixels at their 10% and 90% luminance quantiles (latewood and earlywood).

All colors are linear RGB (Rec. 709 primaries). Colors are varied in Oklab, a perceptual space,
so that a lightness or hue change looks like the same change on every color.
"""

import json
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import numpy as np

with warnings.catch_warnings():  # colour-science warns about optional features
    warnings.simplefilter("ignore")
    import colour

MEASURED_FILE = Path(__file__).with_name("physically-based-materials.json")

SURFACE_METALS = ("Aluminum", "Brass", "Chromium", "Cobalt", "Copper", "Gold", "Iron", "Lead",
                  "Nickel", "Palladium", "Platinum", "Silver", "Stainless Steel", "Titanium",
                  "Tungsten", "Zinc")
"""Metals that real objects are made or plated of. The database's alkali metals, mercury and
semiconductors (germanium, silicon) are left out: no flat sample of them is ever photographed."""

RUSTING_METALS = ("Iron",)
IRON_OXIDE = "Brick"
"""Rust color: the database's brick, whose red is that of iron(III) oxide."""

WOOD_TONES = {
    "godot_texture_wood": {"latewood": (0.245, 0.043, 0.012), "earlywood": (0.791, 0.180, 0.021)},
    "materialx_wood": {"latewood": (0.112, 0.031, 0.010), "earlywood": (0.173, 0.054, 0.013)},
}


@dataclass(frozen=True)
class MeasuredMaterial:
    name: str
    category: str
    color: tuple
    """Linear RGB: F0 for metals, diffuse albedo for dielectrics."""
    metalness: float
    roughness: float
    """Perceptual roughness r; the Ward alpha is r^2."""
    ior: float

    @property
    def specular(self) -> tuple[float, float, float]:
        """Normal-incidence reflectance F0, linear RGB, each channel clipped to [0, 1]."""
        if self.metalness >= 0.5:
            return tuple(float(c) for c in np.clip(self.color, 0.0, 1.0))
        return (fresnel_f0(self.ior),) * 3


@cache
def measured_materials() -> tuple[MeasuredMaterial, ...]:
    """Every material of the bundled database, in file order."""
    entries = json.loads(MEASURED_FILE.read_text())
    return tuple(MeasuredMaterial(entry["name"], entry["category"][0], tuple(entry["color"]),
                                  float(entry["metalness"]), float(entry["roughness"]),
                                  float(entry["ior"])) for entry in entries)


def measured(name: str) -> MeasuredMaterial:
    """The measured material of that name."""
    for material in measured_materials():
        if material.name == name:
            return material
    raise KeyError(f"{name} is not in {MEASURED_FILE.name}")


def plastics() -> tuple[MeasuredMaterial, ...]:
    """The database's plastics (clear resins: their index of refraction is what they give)."""
    return tuple(m for m in measured_materials() if m.category == "Plastic")


def pigment_colors() -> tuple[tuple, ...]:
    """Diffuse albedos of the opaque, colored dielectrics of the database (plastic dyes are
    drawn from these: the database's plastics themselves are clear)."""
    return tuple(m.color for m in measured_materials()
                 if m.metalness < 0.5 and m.category in ("Manmade", "Organic")
                 and max(m.color) < 0.99)


def fresnel_f0(ior: float) -> float:
    """Normal-incidence Fresnel reflectance of a dielectric in air."""
    return float(((ior - 1.0) / (ior + 1.0)) ** 2)


def vary_color(rgb: np.ndarray | Sequence[float], lightness: float = 1.0, chroma: float = 1.0,
               hue_deg: float = 0.0) -> np.ndarray:
    """``rgb`` with its Oklab lightness and chroma scaled and its hue turned; clipped to
    [0.005, 1] (no real surface is perfectly black or reflects more than it receives)."""
    space = colour.RGB_COLOURSPACES["sRGB"]
    lab = colour.XYZ_to_Oklab(colour.RGB_to_XYZ(np.asarray(rgb, np.float64), space))
    turn = np.radians(hue_deg)
    a = lab[..., 1] * np.cos(turn) - lab[..., 2] * np.sin(turn)
    b = lab[..., 1] * np.sin(turn) + lab[..., 2] * np.cos(turn)
    lab = np.stack([lab[..., 0] * lightness, a * chroma, b * chroma], -1)
    rgb = colour.XYZ_to_RGB(colour.Oklab_to_XYZ(lab), space)
    return np.clip(rgb, 0.005, 1.0).astype(np.float32)
