"""Procedural plastic: solid, speckled or patterned, with a molded surface texture and scratches.

- Color: a dye drawn from the measured colors of opaque dielectrics
  (render.materials.procedural.palette.pigment_colors), varied in lightness, chroma and hue.
- Specular: achromatic, F0 from the index of refraction of one of the database's plastics
  (acrylic, PC, PET, PP, PUR, PVC): 0.039 to 0.053.
- Roughness: low to medium (glossy to satin), raised along scratches.
- Surface: orange peel (fine bumps of injection-molded or painted parts), stipple (the raised
  dots of molded casings) or a leather-like grain (grooves along cell edges).

Lengths are in tile units (render.materials.procedural.noise has the frame); all randomness is
drawn in ``sample_parameters`` and recorded, so ``generate(parameters, size)`` is a pure
function.
"""

import numpy as np

from render.materials.procedural.noise import cellular, gaussian_noise, pixel_positions, smoothstep
from render.materials.procedural.palette import fresnel_f0, pigment_colors, plastics, vary_color
from render.materials.procedural.scratches import sample_scratches, scratch_profile
from render.materials.procedural.surface import Surface

APPEARANCES = ("solid", "speckled", "patterned")
PATTERNS = ("stripes", "checker", "dots", "marbled")
SURFACE_TEXTURES = ("orange_peel", "stipple", "grain")
ROUGHNESS_RANGE = (0.08, 0.55)
"""Perceptual roughness, polished to satin; the database's plastics are polished (0), and
molded parts are rarely rougher than satin."""


def _dye(rng):
    colors = pigment_colors()
    base = colors[rng.integers(len(colors))]
    return vary_color(base, rng.uniform(0.8, 1.2), rng.uniform(0.7, 1.6),
                      rng.uniform(-25, 25)).tolist()


def sample_parameters(rng: np.random.Generator) -> dict:
    """Draw every parameter of one plastic material (a JSON-serializable dict)."""
    resin = plastics()[rng.integers(len(plastics()))]
    appearance = str(rng.choice(APPEARANCES))
    parameters = {
        "resin": resin.name,
        "ior": resin.ior,
        "color": _dye(rng),
        "appearance": appearance,
        "mottle_seed": int(rng.integers(2**31)),
        "mottle": float(rng.uniform(0.01, 0.05)),
        "surface_texture": str(rng.choice(SURFACE_TEXTURES)),
        "texture_seed": int(rng.integers(2**31)),
        "texture_scale": float(rng.uniform(0.5, 2.0)),
        "texture_depth": float(rng.uniform(0.00005, 0.0004)),
        "roughness": float(rng.uniform(*ROUGHNESS_RANGE)),
        "scratches": sample_scratches(rng, int(rng.integers(0, 30)), (0.03, 0.35),
                                      (0.001, 0.004)),
        "scratch_depth": float(rng.uniform(0.0002, 0.001)),
    }
    if appearance == "speckled":
        parameters["speckle"] = {"seed": int(rng.integers(2**31)),
                                 "count": int(rng.integers(300, 4000)),
                                 "radius": float(rng.uniform(0.002, 0.007)),
                                 "colors": [_dye(rng) for _ in range(rng.integers(1, 4))]}
    elif appearance == "patterned":
        parameters["pattern"] = {"kind": str(rng.choice(PATTERNS)),
                                 "frequency": 2 * int(rng.integers(1, 6)),  # even: checkers tile
                                 "direction": [int(rng.integers(0, 3)), int(rng.integers(1, 3))],
                                 "seed": int(rng.integers(2**31)),
                                 "color": _dye(rng)}
    return parameters


def generate(parameters: dict, size: int) -> Surface:
    """The plastic surface of ``parameters`` sampled on a size x size tile."""
    p = parameters
    x, y = pixel_positions(size)
    albedo = np.broadcast_to(np.asarray(p["color"]), (size, size, 3)).copy()
    if p["appearance"] == "speckled":
        albedo = _speckles(albedo, p["speckle"], size)
    elif p["appearance"] == "patterned":
        mask = _pattern_mask(p["pattern"], x, y, size)[..., None]
        albedo = albedo * (1 - mask) + np.asarray(p["pattern"]["color"]) * mask
    mottle = gaussian_noise(size, p["mottle_seed"], 1, 8, slope=1.0)
    albedo = albedo * (1.0 + p["mottle"] * mottle)[..., None]

    scratches = scratch_profile(p["scratches"], x, y)
    albedo = albedo + (0.12 * scratches)[..., None]  # stress whitening: scattering in the groove
    height = p["texture_depth"] * _surface_texture(p, size) - p["scratch_depth"] * scratches
    roughness = np.minimum(p["roughness"] + 0.35 * scratches, 1.0)
    return Surface(albedo.astype(np.float32), height, np.full(3, fresnel_f0(p["ior"])), roughness)


def _speckles(albedo, speckle, size):
    """Flecks of other dyes, one color per fleck, in irregular round shapes."""
    nearest, _, cell = cellular(size, speckle["seed"], speckle["count"])
    shape = 1.0 + 0.35 * gaussian_noise(size, speckle["seed"] + 1, 40, 160, slope=0.0)
    fleck = 1.0 - smoothstep(0.7, 1.0, nearest * shape / speckle["radius"])
    palette = np.asarray(speckle["colors"])
    fleck_color = palette[cell % len(palette)]
    return albedo * (1 - fleck[..., None]) + fleck_color * fleck[..., None]


def _pattern_mask(pattern, x, y, size):
    """Second-color coverage in [0, 1] of a printed or molded two-color pattern."""
    a, b = pattern["direction"]
    frequency = pattern["frequency"]
    if pattern["kind"] == "stripes":
        phase = np.mod((a * x + b * y) * frequency, 1.0)
        return smoothstep(0.45, 0.5, phase) * (1 - smoothstep(0.95, 1.0, phase))
    if pattern["kind"] == "checker":
        return ((np.floor(x * frequency) + np.floor(y * frequency)) % 2).astype(float)
    if pattern["kind"] == "dots":
        dx = np.mod(x * frequency, 1.0) - 0.5
        dy = np.mod(y * frequency, 1.0) - 0.5
        return 1.0 - smoothstep(0.25, 0.3, np.hypot(dx, dy))
    warped = gaussian_noise(size, pattern["seed"], 1, 4, slope=1.0)  # marbled
    veins = np.sin(2 * np.pi * (x * frequency + 0.6 * warped))
    return smoothstep(0.3, 0.7, veins)


def _surface_texture(p, size):
    """Unit-scale height of the molded surface texture."""
    scale = p["texture_scale"]
    if p["surface_texture"] == "orange_peel":
        return gaussian_noise(size, p["texture_seed"], 10 * scale, 60 * scale, slope=1.0)
    nearest, second, _ = cellular(size, p["texture_seed"], int(400 * scale ** 2))
    spacing = 1.0 / np.sqrt(400 * scale ** 2)
    if p["surface_texture"] == "stipple":
        return 1.0 - smoothstep(0.15, 0.35, nearest / spacing)
    return -(1.0 - smoothstep(0.0, 0.08, (second - nearest) / spacing))  # grain: edge grooves
