"""Procedural wood: growth rings, grain direction, pores, knots and plank seams.

Two layouts:
- ``planks``: flat-sawn boards laid side by side and end to end. Each board is cut from its own
  log: its rings are the intersections of the trunk's cylindrical growth rings with the board's
  face, ``r = sqrt((across - pith_offset)^2 + (pith_depth + taper * along)^2)``, which gives the
  arches ("cathedrals") of flat-sawn wood; seams run between boards, joints across them.
- ``panel``: one quarter-sawn surface without seams, its rings straight stripes.

The grain runs along an integer lattice direction (a, b) of the tile (x right, y down), so
every pattern wraps at the tile's edges: ``s = a x + b y`` and ``t = -b x + a y`` advance by
integers across the tile, and everything is a function of their fractional parts. Lengths are
in tile units (see render.materials.procedural.noise for the frame); all randomness is drawn in
``sample_parameters`` and recorded, so ``generate(parameters, size)`` is a pure function.

Colors come from the real wood sets (render.materials.procedural.palette.WOOD_TONES), F0 from
an index of refraction of 1.5 (cellulose, and the varnish on finished wood).
"""

import numpy as np

from render.materials.procedural.noise import (gaussian_noise, pixel_positions, smoothstep,
                                               wrapped_offset)
from render.materials.procedural.palette import WOOD_TONES, fresnel_f0, vary_color
from render.materials.procedural.surface import Surface

GRAIN_DIRECTIONS = ((1, 0), (0, 1), (1, 1), (1, -1), (2, 1), (1, 2), (2, -1), (1, -2))
GRAIN_DIRECTION_WEIGHTS = (3, 3, 1, 1, 0.5, 0.5, 0.5, 0.5)
WOOD_IOR = 1.5
FINISH_ROUGHNESS = {"varnished": (0.2, 0.45), "raw": (0.55, 0.85)}
"""Perceptual roughness ranges per finish; the bundled database gives 0.5 to 0.9 for raw organic
matter and 0 for lacquered surfaces (car paint, porcelain); varnish is rarely that glossy."""


def sample_parameters(rng: np.random.Generator) -> dict:
    """Draw every parameter of one wood material (a JSON-serializable dict)."""
    a, b = GRAIN_DIRECTIONS[rng.choice(len(GRAIN_DIRECTIONS),
                                       p=np.divide(GRAIN_DIRECTION_WEIGHTS,
                                                   sum(GRAIN_DIRECTION_WEIGHTS)))]
    lattice_length = float(np.hypot(a, b))
    layout = "planks" if rng.random() < 0.75 else "panel"
    planks_across = [n for n in range(1, 6) if 0.12 <= 1 / (lattice_length * n) <= 0.5]
    pieces_along = [m for m in range(1, 4) if 1 / (lattice_length * m) >= 0.3]
    across = int(rng.choice(planks_across)) if layout == "planks" else 1
    along = int(rng.choice(pieces_along)) if layout == "planks" else 1
    plank_width = 1 / (lattice_length * across)
    boards = [{"pith_offset": float(rng.uniform(-0.5, 0.5) * plank_width),
               "pith_depth": float(rng.uniform(0.03, 0.5)),
               "taper": float(rng.uniform(-0.4, 0.4)),
               "tone": float(rng.uniform(0.85, 1.15)),
               "hue_deg": float(rng.normal(0.0, 3.0))} for _ in range(across * along)]
    source = str(rng.choice(sorted(WOOD_TONES)))
    lightness, chroma, hue = rng.uniform(0.75, 1.25), rng.uniform(0.45, 1.0), rng.normal(0, 6)
    tones = {name: vary_color(rgb, lightness, chroma, hue).tolist()
             for name, rgb in WOOD_TONES[source].items()}
    finish = str(rng.choice(sorted(FINISH_ROUGHNESS)))
    knots = [{"x": float(rng.random()), "y": float(rng.random()),
              "radius": float(rng.uniform(0.01, 0.035)), "stretch": float(rng.uniform(1.2, 2.5))}
             for _ in range(rng.choice(4, p=(0.45, 0.3, 0.15, 0.1)))]
    return {
        "layout": layout,
        "direction": [a, b],
        "planks_across": across,
        "pieces_along": along,
        "stagger": [float(rng.random()) for _ in range(across)],
        "boards": boards,
        "ring_density": float(rng.uniform(12.0, 60.0)),
        "latewood_sharpness": float(rng.uniform(1.5, 6.0)),
        "ring_warp": float(rng.uniform(0.002, 0.02)),
        "ring_warp_seed": int(rng.integers(2**31)),
        "knots": knots,
        "pore_seed": int(rng.integers(2**31)),
        "pore_threshold": float(rng.uniform(1.6, 2.6)),
        "pores_in_earlywood": bool(rng.random() < 0.5),
        "pore_depth": float(rng.uniform(0.00005, 0.0003)),
        "fibre_seed": int(rng.integers(2**31)),
        "fibre_contrast": float(rng.uniform(0.03, 0.12)),
        "tones_from": source,
        "earlywood": tones["earlywood"],
        "latewood": tones["latewood"],
        "finish": finish,
        "roughness": float(rng.uniform(*FINISH_ROUGHNESS[finish])),
        "seam_width": float(rng.uniform(0.002, 0.006)),
        "seam_depth": float(rng.uniform(0.001, 0.004)),
    }


def generate(parameters: dict, size: int) -> Surface:
    """The wood surface of ``parameters`` sampled on a size x size tile."""
    p = parameters
    a, b = p["direction"]
    lattice_length = float(np.hypot(a, b))
    grain_angle = float(np.degrees(np.arctan2(-b, a)))  # on screen, y up
    x, y = pixel_positions(size)
    s, t = a * x + b * y, -b * x + a * y

    warp = p["ring_warp"] * gaussian_noise(size, p["ring_warp_seed"], 1, 6, slope=1.5,
                                           stretch=3.0, angle_deg=grain_angle)
    if p["layout"] == "planks":
        ring_radius, board, seam = _planks(p, s, t, lattice_length)
    else:  # quarter-sawn panel: straight rings, an integer number per period of t
        rings = max(1, round(p["ring_density"] / lattice_length))
        ring_radius = np.mod(t, 1.0) * rings / p["ring_density"]
        board, seam = np.zeros(x.shape, int), np.zeros(x.shape)
    ring_radius = ring_radius + warp
    knot_core = np.zeros(x.shape)
    for knot in p["knots"]:
        distance = _knot_distance(knot, x, y, a / lattice_length, b / lattice_length)
        ring_radius = ring_radius + 2.0 * knot["radius"] * np.exp(-(distance / 1.8) ** 2)
        knot_core = np.maximum(knot_core, 1.0 - smoothstep(0.7, 1.0, distance))

    phase = np.mod(ring_radius * p["ring_density"], 1.0)
    latewood = phase ** p["latewood_sharpness"]
    earlywood = np.asarray(p["earlywood"])
    latewood_color = np.asarray(p["latewood"])
    albedo = earlywood + (latewood_color - earlywood) * latewood[..., None]

    fibre = gaussian_noise(size, p["fibre_seed"], 8, 160, slope=0.5, stretch=25.0,
                           angle_deg=grain_angle)
    pores = smoothstep(p["pore_threshold"], p["pore_threshold"] + 0.8,
                       gaussian_noise(size, p["pore_seed"], 40, 220, slope=0.0, stretch=8.0,
                                      angle_deg=grain_angle))
    if p["pores_in_earlywood"]:
        pores = pores * (1.0 - latewood)
    tone = np.array([board_parameters["tone"] for board_parameters in p["boards"]])[board]
    albedo = albedo * (tone * (1.0 + p["fibre_contrast"] * fibre) * (1.0 - 0.5 * pores))[..., None]
    albedo = _hue_per_board(albedo, board, p["boards"])
    albedo = albedo * (1.0 - 0.45 * knot_core)[..., None] * (1.0 - 0.6 * seam)[..., None]

    height = (-p["pore_depth"] * pores - p["seam_depth"] * seam + 0.0001 * fibre
              + 0.0008 * knot_core)
    if p["finish"] == "raw":  # weathered: the softer earlywood wears below the latewood
        height = height + 0.0004 * latewood
    return Surface(albedo.astype(np.float32), height, np.full(3, fresnel_f0(WOOD_IOR)),
                   p["roughness"])


def _planks(p, s, t, lattice_length):
    """Ring radius, board index and seam profile (1 in a seam, 0 away) of the planks layout."""
    across, along = p["planks_across"], p["pieces_along"]
    width, length = 1 / (lattice_length * across), 1 / (lattice_length * along)
    t_planks = np.mod(t, 1.0) * across
    plank = np.minimum(t_planks.astype(int), across - 1)
    across_centre = (t_planks - plank - 0.5) * width
    s_pieces = np.mod(s + np.asarray(p["stagger"])[plank], 1.0) * along
    piece = np.minimum(s_pieces.astype(int), along - 1)
    along_start = (s_pieces - piece) * length
    board = plank * along + piece

    offset = np.array([b["pith_offset"] for b in p["boards"]])[board]
    depth = np.array([b["pith_depth"] for b in p["boards"]])[board]
    taper = np.array([b["taper"] for b in p["boards"]])[board]
    radius = np.hypot(across_centre - offset, depth + taper * along_start)

    to_side = (0.5 - np.abs(t_planks - plank - 0.5)) * width
    to_end = (0.5 - np.abs(s_pieces - piece - 0.5)) * length
    seam = 1.0 - smoothstep(0.0, p["seam_width"], np.minimum(to_side, to_end))
    return radius, board, seam


def _knot_distance(knot, x, y, direction_x, direction_y):
    """Distance to a knot in knot radii, the knot elongated along the grain."""
    dx, dy = wrapped_offset(x, y, knot["x"], knot["y"])
    along = (dx * direction_x + dy * direction_y) / knot["stretch"]
    across = -dx * direction_y + dy * direction_x
    return np.hypot(along, across) / knot["radius"]


def _hue_per_board(albedo, board, boards):
    """Each board's slight hue shift (boards from different logs never match exactly)."""
    shifted = np.empty_like(albedo)
    for index, parameters in enumerate(boards):
        mask = board == index
        if mask.any():
            shifted[mask] = vary_color(albedo[mask], hue_deg=parameters["hue_deg"])
    return shifted
