"""Procedural metal: brushed, hammered, scratched or corroded, with a colored specular albedo.

- Specular: F0 of one of the database's surface metals (render.materials.procedural.palette),
  so gold is yellow, copper orange and steel gray.
- Diffuse: dark, a thin film of oxide and grime tinted like the metal, a few percent of F0.
- Finishes: ``brushed`` (fine streaks along one direction), ``hammered`` (overlapping round
  dents), ``scratched`` (polished, with scratches in all directions), ``corroded`` (iron with
  rust patches and pits; rust is a rough dielectric with the color of iron oxide).
- Roughness: per finish below. The database's metals are polished (0); finishes make them
  rougher. Per pixel, rust has F0 0.04 and roughness 0.9, and the homogeneous values are the
  means over the tile (render.materials.procedural.surface), as for the real sets.

Lengths are in tile units (render.materials.procedural.noise has the frame); all randomness is
drawn in ``sample_parameters`` and recorded, so ``generate(parameters, size)`` is a pure
function.
"""

import numpy as np

from render.materials.procedural.noise import cellular, gaussian_noise, pixel_positions, smoothstep
from render.materials.procedural.palette import (IRON_OXIDE, RUSTING_METALS, SURFACE_METALS,
                                                 fresnel_f0, measured, vary_color)
from render.materials.procedural.scratches import sample_scratches, scratch_profile
from render.materials.procedural.surface import Surface

FINISHES = ("brushed", "hammered", "scratched", "corroded")
FINISH_ROUGHNESS = {"brushed": (0.25, 0.5), "hammered": (0.1, 0.35), "scratched": (0.05, 0.2),
                    "corroded": (0.3, 0.55)}
RUST_ROUGHNESS = 0.9
RUST_IOR = 1.5


def sample_parameters(rng: np.random.Generator) -> dict:
    """Draw every parameter of one metal material (a JSON-serializable dict)."""
    finish = str(rng.choice(FINISHES))
    metals = RUSTING_METALS if finish == "corroded" else SURFACE_METALS
    metal = measured(str(rng.choice(metals)))
    parameters = {
        "metal": metal.name,
        "f0": list(metal.specular),
        "finish": finish,
        "roughness": float(rng.uniform(*FINISH_ROUGHNESS[finish])),
        "film": float(rng.uniform(0.02, 0.08)),
        "grime_seed": int(rng.integers(2**31)),
        "grime": float(rng.uniform(0.05, 0.3)),
    }
    if finish == "brushed":
        parameters["brush"] = {"seed": int(rng.integers(2**31)),
                               "angle_deg": float(rng.choice([0.0, 90.0, rng.uniform(0, 180)])),
                               "stretch": float(rng.uniform(40, 200)),
                               "depth": float(rng.uniform(0.00005, 0.0002))}
    elif finish == "hammered":
        parameters["dents"] = {"seed": int(rng.integers(2**31)),
                               "count": int(rng.integers(20, 250)),
                               "depth": float(rng.uniform(0.002, 0.008))}
    elif finish == "corroded":
        rust = measured(IRON_OXIDE).color
        parameters["rust"] = {"seed": int(rng.integers(2**31)),
                              "coverage_threshold": float(rng.uniform(-0.5, 1.0)),
                              "color": vary_color(rust, rng.uniform(0.6, 1.1),
                                                  rng.uniform(0.7, 1.1),
                                                  rng.uniform(-10, 10)).tolist(),
                              "pit_seed": int(rng.integers(2**31)),
                              "pit_depth": float(rng.uniform(0.0005, 0.002))}
    scratch_count = {"scratched": (30, 150), "brushed": (0, 10)}.get(finish, (0, 8))
    parameters["scratches"] = sample_scratches(rng, int(rng.integers(*scratch_count)),
                                               (0.05, 0.5), (0.001, 0.003))
    parameters["scratch_depth"] = float(rng.uniform(0.0001, 0.0006))
    return parameters


def generate(parameters: dict, size: int) -> Surface:
    """The metal surface of ``parameters`` sampled on a size x size tile."""
    p = parameters
    x, y = pixel_positions(size)
    f0 = np.asarray(p["f0"])
    grime = 1.0 + p["grime"] * gaussian_noise(size, p["grime_seed"], 1, 10, slope=1.0)
    albedo = (p["film"] * f0)[None, None, :] * np.clip(grime, 0.2, None)[..., None]
    height = np.zeros((size, size))
    roughness = np.full((size, size), p["roughness"])
    specular = np.broadcast_to(f0, (size, size, 3))

    if p["finish"] == "brushed":
        brush = p["brush"]
        streaks = gaussian_noise(size, brush["seed"], 30, 250, slope=0.5,
                                 stretch=brush["stretch"], angle_deg=brush["angle_deg"])
        height += brush["depth"] * streaks
        albedo = albedo * (1.0 + 0.15 * streaks[..., None])
    elif p["finish"] == "hammered":
        dents = p["dents"]
        nearest, _, _ = cellular(size, dents["seed"], dents["count"])
        spacing = 1.0 / np.sqrt(dents["count"])
        height += dents["depth"] * (nearest / spacing) ** 2  # paraboloid dents, ridges between
    elif p["finish"] == "corroded":
        rust_parameters = p["rust"]
        rust = smoothstep(rust_parameters["coverage_threshold"],
                          rust_parameters["coverage_threshold"] + 0.6,
                          gaussian_noise(size, rust_parameters["seed"], 2, 64, slope=1.2))
        pits, _, _ = cellular(size, rust_parameters["pit_seed"], 1500)
        pit = (1.0 - smoothstep(0.0, 0.006, pits)) * rust
        height += 0.0006 * rust - rust_parameters["pit_depth"] * pit
        rust_color = np.asarray(rust_parameters["color"]) * (1.0 - 0.5 * pit)[..., None]
        albedo = albedo * (1 - rust[..., None]) + rust_color * rust[..., None]
        specular = specular * (1 - rust[..., None]) + fresnel_f0(RUST_IOR) * rust[..., None]
        roughness = roughness * (1 - rust) + RUST_ROUGHNESS * rust

    scratches = scratch_profile(p["scratches"], x, y)
    height -= p["scratch_depth"] * scratches
    roughness = np.minimum(roughness + 0.3 * scratches, 1.0)
    albedo = albedo + (0.05 * scratches[..., None]) * f0  # light scattered in the groove
    return Surface(albedo.astype(np.float32), height, specular, roughness)
