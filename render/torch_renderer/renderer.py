"""A batched, differentiable torch renderer of the reduced SVBRDF under distant probes.

It renders what ``render/mitsuba_reference/scene.py`` renders with Mitsuba, in the same
conventions (docs/conventions.md): texture-space images, (B, 3, H, W) linear RGB, row 0 at the
top; normals in tangent space (x right, y up, z out); probes white-balanced to a plane
irradiance of pi, rotated counter-clockwise about +z; light only from above the sample plane.
It needs torch alone (no Mitsuba) and runs on any device and dtype; its one per-sample Python
loop computes the broad-lobe tables, each sample's with matrix products.

Method. With an orthographic view and distant light, a texel's radiance depends on the texel
only through its albedo and its normal n:

    L(x) = rho_d(x) * D(n) + rho_s * S(n) / sqrt(n.v)
    D(n) = 1/pi  * integral over z > 0 of L_probe(w) max(n.w, 0) dw
    S(n) = integral over z > 0 of L_probe(w) ward(w, v, n) max(n.w, 0) sqrt(n.v) dw,  rho_s = 1

(zero where the view is behind the normal, n.v <= 0). Ward's view factor 1 / sqrt(n.v) grows
without bound toward the view's horizon and is applied per pixel; S without it is smooth in n.
Per sample, D and S are tabulated over normal directions covering the sample's normals, with
one entry of margin, and looked up per pixel by Catmull-Rom bicubic interpolation.
Normals are parameterized stereographically, p = (n_x, n_y) / (1 + n_z): the map is conformal,
so a lobe stays round in p, and a table cell of size c spans an angle of at most 2 c.

The probe is integrated as Mitsuba sees it, the bilinear interpolant of its samples: each
sample (node) carries the integral of its bilinear "tent" times sin(theta), cut at the
horizon; for sharp lobes the probe is first resampled finer (which leaves the interpolant
unchanged) so that nodes stay a fraction of the lobe width apart (NODES_PER_SIGMA).
- D: nodes are gathered in blocks about DIFFUSE_BLOCK_ANGLE wide, each at its energy's mean
  direction (exact for a block the normal sees whole); DIFFUSE_TABLE^2 table entries.
- S, sharp lobes (roughness < BROAD_ROUGHNESS): every node's energy is splatted bilinearly
  onto a lattice in half-vector space (stereographic coordinates of h = normalize(w + v));
  S at a table normal is the sum of the lattice energies within STENCIL_SIGMAS lobe widths,
  weighted by the Ward kernel at the lattice half vectors (its alpha corrected for the
  quadrature's blurs, _blur_compensated_roughness). Lattice and table share one spacing, a
  fixed fraction of the lobe width (CELLS_PER_SIGMA), so the cost per table entry does not
  depend on roughness.
- S, broad lobes: the kernel (alpha corrected likewise) summed over probe blocks a fixed
  fraction of the lobe wide (GLOSSY_BLOCK_ANGLE at BROAD_ROUGHNESS, at most
  MAX_GLOSSY_BLOCK_ANGLE), on a finer table (BROAD_CELLS_PER_SIGMA), because near-horizon
  light makes S change faster with n than the lobe width alone suggests.
Only the table entries that some pixel's lookup touches are computed. Spacings are rounded to
quarter octaves and table ranges snapped to the lattice, so the discretization does not move
under small changes of the inputs: the output is differentiable in the maps, the specular
albedo and the roughness (gradcheck-ed in float64). Measured accuracy and speed:
docs/torch-renderer.md.
"""

import math
from collections.abc import Sequence

import numpy as np
import torch
from torch.utils.checkpoint import checkpoint

from render.common.color import REC709_LUMINANCE
from render.common.probes import latitude_weights, plane_irradiance
from render.materials.reduced_svbrdf import ALPHA_RANGE

DIFFUSE_BLOCK_ANGLE = 0.1  # radians
GLOSSY_BLOCK_ANGLE = 0.05
MAX_GLOSSY_BLOCK_ANGLE = 0.1  # wider blocks misplace light: 36 dB at alpha 1 (drachenfels_cellar)
DIFFUSE_TABLE = 27  # 24 cells over the table range, one entry of margin each side
CELLS_PER_SIGMA = 1.75
BROAD_CELLS_PER_SIGMA = 4.0
STENCIL_SIGMAS = 4.0  # at 3, the cut tail cost 0.7% of S and 3x in dS/dalpha
NODES_PER_SIGMA = 3.0
MAX_REFINEMENT = 8
BROAD_ROUGHNESS = 0.12
ENTRY_CHUNK_LANES = 1 << 20  # (table entries x stencil cells) evaluated at once
KEPT_LANES = 1 << 25  # lanes whose intermediates a differentiated render keeps (about 2.7 GB)


class ProbeBank:
    """Probes prepared for the torch renderer: white-balanced quadrature nodes of the upper
    hemisphere, in the probe's own frame (rotation 0). All probes must share one size.

    ``radiances``: a sequence of (H, 2H, 3) linear RGB arrays (white-balanced or not: they are
    balanced here exactly as ``render.common.probes.load_probe`` does).
    """

    def __init__(self, radiances: Sequence[np.ndarray], device: str | torch.device = "cpu",
                 dtype: torch.dtype = torch.float32):
        radiances = [np.asarray(r, np.float64) for r in radiances]
        shapes = {r.shape for r in radiances}
        if len(shapes) != 1:
            raise ValueError(f"probes of one bank must share a size, got {sorted(shapes)}")
        self.radiance = np.stack([r * (np.pi / plane_irradiance(r)) for r in radiances])
        self.height = self.radiance.shape[1]
        self.device, self.dtype = device, dtype
        self._nodes, self._blocks = {}, {}

    def __len__(self):
        return self.radiance.shape[0]

    def _tensor(self, array):
        return torch.as_tensor(np.ascontiguousarray(array), dtype=self.dtype, device=self.device)

    def nodes(self, factor: int) -> tuple[torch.Tensor, torch.Tensor]:
        """Quadrature nodes at ``factor`` times the probe resolution: energies (P, N, 3) and
        directions (N, 3). Cached."""
        if factor not in self._nodes:
            energy, directions = _refined_nodes(self.radiance, factor)
            self._nodes[factor] = (self._tensor(energy.reshape(len(self), -1, 3)),
                                   self._tensor(directions.reshape(-1, 3)))
        return self._nodes[factor]

    def blocks(self, size: int) -> tuple[torch.Tensor, torch.Tensor]:
        """The probe's nodes gathered in size x size blocks: energies (P, N, 3) and
        luminance-weighted mean directions (P, N, 3). Cached."""
        if size not in self._blocks:
            self._blocks[size] = tuple(
                self._tensor(a) for a in _blocks(*_refined_nodes(self.radiance, 1), size))
        return self._blocks[size]


def _refined_nodes(radiance, factor):
    """The probe's bilinear interpolant sampled on a grid that splits each cell into
    ``factor`` x ``factor`` (which leaves the interpolant unchanged), rows above the horizon
    only. Each node's energy is its radiance times the integral of its tent times sin(theta).
    Returns energies (P, R, W', 3) and directions (R, W', 3), W' = factor W."""
    count, height, width, _ = radiance.shape
    weights = latitude_weights(factor * (height - 1) + 1, np.sin)
    kept = int(np.flatnonzero(weights > 0)[-1]) + 1
    row = np.arange(kept) / factor  # in units of the probe's rows and columns
    col = np.arange(factor * width) / factor
    r0 = np.minimum(np.floor(row).astype(int), height - 2)
    c0 = np.floor(col).astype(int)
    fr, fc = (row - r0)[:, None, None], (col - c0)[:, None]
    energy = np.empty((count, kept, factor * width, 3), np.float32)
    for index, probe in enumerate(radiance):
        rows = probe[r0] * (1 - fr) + probe[r0 + 1] * fr
        energy[index] = rows[:, c0] * (1 - fc) + rows[:, (c0 + 1) % width] * fc
    energy *= (weights[:kept] * (2 * np.pi / (factor * width)))[:, None, None]
    theta = (np.pi * row / (height - 1))[:, None]
    phi = (-2 * np.pi * (col + 0.5) / width)[None, :]
    directions = np.stack(np.broadcast_arrays(
        np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)), -1)
    return energy, directions


def _blocks(energy, directions, size):
    """Sum energies over size x size nodes, and the blocks' luminance-weighted mean directions
    (not normalized: the diffuse term of a block that the normal sees whole is then exact;
    the plain mean where a block holds no light). (P, N, 3) twice."""
    pad = -energy.shape[1] % size
    energy = np.pad(energy, ((0, 0), (0, pad), (0, 0), (0, 0)))
    directions = np.pad(directions, ((0, pad), (0, 0), (0, 0)), mode="edge")
    count, rows, width, _ = energy.shape
    shape = (count, rows // size, size, width // size, size, 3)
    block_energy = energy.reshape(shape).sum(axis=(2, 4))
    weight = energy @ np.array(REC709_LUMINANCE)
    total = weight.reshape(shape[:-1]).sum(axis=(2, 4))[..., None]
    weighted = (directions[None] * weight[..., None]).reshape(shape).sum(axis=(2, 4))
    plain = directions.reshape(shape[1:]).mean(axis=(1, 3))
    mean = np.where(total > 0, weighted / np.maximum(total, 1e-300), plain[None])
    return block_energy.reshape(count, -1, 3), mean.reshape(count, -1, 3)


def stereographic(n: torch.Tensor) -> torch.Tensor:
    """Unit vectors (..., 3) with z > -1 to stereographic coordinates (..., 2)."""
    return n[..., :2] / (1 + n[..., 2:3])


def inverse_stereographic(p: torch.Tensor) -> torch.Tensor:
    """Stereographic coordinates (..., 2) to unit vectors (..., 3)."""
    q = (p * p).sum(-1, keepdim=True)
    return torch.cat([2 * p, 1 - q], -1) / (1 + q)


def rotate_z(vectors: torch.Tensor, rotation_deg: torch.Tensor) -> torch.Tensor:
    """Rotate (B, N, 3) vectors counter-clockwise about +z by (B,) degrees."""
    angle = torch.deg2rad(rotation_deg)[:, None]
    c, s = torch.cos(angle), torch.sin(angle)
    x, y, z = vectors.unbind(-1)
    return torch.stack([c * x - s * y, s * x + c * y, z], -1)


def ward_kernel(cos_h: torch.Tensor, cos_i: torch.Tensor, cos_o: torch.Tensor,
                alpha: torch.Tensor | float) -> torch.Tensor:
    """Ward lobe times cosine, f_s cos(theta_i) / rho_s, from the cosines of the half vector,
    the light and the view with the normal; zero where the light or the view is behind the
    normal (see _ward_lobe for the half vector)."""
    view_factor = torch.where(cos_o > 0, cos_o, torch.inf).rsqrt()  # zero behind the normal
    return _ward_lobe(cos_h, cos_i, alpha) * view_factor


def _ward_lobe(cos_h, cos_i, alpha):
    """f_s cos(theta_i) sqrt(cos(theta_o)) / rho_s: the Ward kernel without its view factor
    1 / sqrt(cos(theta_o)), which is smooth in the normal up to and across the view's horizon
    (the tables hold it; render() applies the view factor per pixel).

    Written for few passes over large (entries x probe blocks) arrays: a half vector at or
    behind the normal's horizon is floored at cos_h = 1e-3, and the exponent at -80 (a relative
    weight below 1e-34, where exp would otherwise take the slow path of results near or below
    the smallest normal float, about 20x slower); the light's cosine is floored at zero."""
    a2 = alpha * alpha
    inverse_cos_h2 = cos_h.clamp(min=1e-3).pow(-2)
    lobe = torch.exp(((1 - inverse_cos_h2) / a2).clamp(min=-80)) / (4 * math.pi * a2)
    return lobe * cos_i.clamp(min=0).sqrt()


class _Layout:
    """Per-sample discretization: lattice spacing, table origin and size (in lattice steps),
    which lobe path (sharp or broad), probe block size (broad), stencil radius (in steps,
    shared by the sharp samples of the batch) and probe refinement factor (sharp)."""

    def __init__(self, p_pixels, roughness, probe_height):
        with torch.no_grad():
            sigma = roughness.detach().double() / math.sqrt(2)  # angular std of the half vector
            broad = roughness.detach() >= BROAD_ROUGHNESS  # computed from probe blocks
            cells = torch.where(broad, BROAD_CELLS_PER_SIGMA, CELLS_PER_SIGMA).double()
            step = sigma / (2 * cells)  # the stereographic map halves angles at +z
            step = torch.exp2(torch.floor(4 * torch.log2(step)) / 4)
            flat = p_pixels.detach().double().flatten(1, 2)  # (B, HW, 2)
            # One entry of margin beyond the pixels' range on each side: a bicubic lookup
            # reads one entry before and two after its cell, so every lookup then reads
            # computed entries, never the border padding (which would bend the interpolant
            # and halve its slope at the edge).
            low = torch.floor(flat.amin(1) / step[:, None]) - 1
            high = torch.maximum(torch.ceil(flat.amax(1) / step[:, None]), low + 2) + 1
            corner = torch.maximum(low.abs(), high.abs()) * step[:, None]
            outer = torch.sqrt((corner * corner).sum(-1))  # largest |p| in the table
            theta = 2 * torch.atan(outer)
            reach = STENCIL_SIGMAS * sigma
            outward = torch.tan(torch.clamp(theta + reach, max=math.pi / 2) / 2) - outer
            inward = outer - torch.tan(torch.clamp(theta - reach, min=-math.pi / 2) / 2)
            radius = torch.minimum(torch.maximum(outward, inward), 1 + outer)
            spacing = node_spacing(probe_height)
            lobe = 2 * sigma  # angular std of the reflected direction
            factor = torch.exp2(torch.ceil(torch.log2(NODES_PER_SIGMA * spacing / lobe)))
        self.step = step
        self.origin = low  # (B, 2): table entry (0, 0) sits at p = origin * step
        self.size = (high - low).long() + 1  # (B, 2) entries per axis (x, y)
        self.table = int(self.size.max())
        self.broad = broad  # (B,)
        # Probe blocks for broad lobes: GLOSSY_BLOCK_ANGLE wide at BROAD_ROUGHNESS and in
        # proportion to roughness above, so a block stays a fixed fraction of the lobe.
        width = torch.clamp(GLOSSY_BLOCK_ANGLE * roughness.detach().double() / BROAD_ROUGHNESS,
                            max=MAX_GLOSSY_BLOCK_ANGLE)
        self.block = block_size(width, probe_height)
        sharp_radius = torch.ceil(radius / step)[~self.broad]
        self.radius = int(sharp_radius.max()) if len(sharp_radius) else 0
        self.lattice = self.table + 2 * self.radius
        self.refinement = factor.clamp(1, MAX_REFINEMENT).long()  # (B,)


def node_spacing(probe_height: int) -> float:
    """The angular spacing (radians) of a probe's samples, rows from zenith to nadir."""
    return math.pi / (probe_height - 1)


def block_size(angle: float | torch.Tensor, probe_height: int) -> torch.Tensor:
    """Nodes per side of the probe blocks at most ``angle`` radians wide: a power of two."""
    angle = torch.as_tensor(angle, dtype=torch.float64)
    log2_nodes = torch.floor(torch.log2(angle / node_spacing(probe_height))).clamp(0, 5)
    return torch.exp2(log2_nodes).long()


def _lattice_directions(origin, step, first, size):
    """Unit vectors (B, size, size, 3) at the lattice points p = (origin + first + (x, y)) step
    for x, y in [0, size), of samples with origins (B, 2) and steps (B,)."""
    index = torch.arange(size, dtype=origin.dtype, device=origin.device) + first
    px = (index[None, None, :] + origin[:, 0, None, None]).expand(-1, size, -1)
    py = (index[None, :, None] + origin[:, 1, None, None]).expand(-1, -1, size)
    return inverse_stereographic(torch.stack([px, py], -1) * step[:, None, None, None])


def _table_coordinates(p, step, origin):
    """Continuous table coordinates (B, H, W, 2) of stereographic points p (B, H, W, 2)."""
    return p / step.to(p.dtype)[:, None, None, None] - origin.to(p.dtype)[:, None, None, :]


def _cell_corners(coordinates, sizes):
    """Lower-left entries (B, H, W, 2) of the cells holding ``coordinates`` (B, H, W, 2), in
    entries (x, y), of tables with (B, 2) entries per axis: at least 1 and at most size - 3,
    so that the four entries per axis a lookup reads, corner - 1 to corner + 2, lie in the
    table (the layout's margin keeps every coordinate in [1, size - 2])."""
    limit = (sizes - 3).to(coordinates.device)[:, None, None, :]
    return torch.minimum(torch.floor(coordinates.detach()).long().clamp(min=1), limit)


def _catmull_rom_weights(t):
    """The four Catmull-Rom weights of entries -1, 0, 1, 2 at fractions t in [0, 1]."""
    t2, t3 = t * t, t * t * t
    return ((2 * t2 - t3 - t) / 2, (3 * t3 - 5 * t2 + 2) / 2, (4 * t2 - 3 * t3 + t) / 2,
            (t3 - t2) / 2)


def _lookup(table, coordinates, sizes):
    """Bicubic (Catmull-Rom) lookup of tables (B, C, T, T) at coordinates (B, H, W, 2) in
    entries (x, y), each sample's table holding (B, 2) entries per axis: (B, C, H, W). The
    interpolant's small overshoots below zero are clamped.

    Catmull-Rom is the cubic convolution that reproduces quadratics (third-order accurate) and
    whose slope at an entry is the central difference of its neighbours; torch's grid_sample
    "bicubic" (cubic convolution with a = -0.75) is first-order accurate and has 1.5 times
    that slope at entries, which showed as normal-map gradients 1.5x Mitsuba's. Per axis, the
    two inner weights are positive, so their two entries are one linear fetch between them:
    the lookup is 3 x 3 bilinear grid_sample fetches, exactly the 4 x 4 Catmull-Rom sum."""
    size = table.shape[-1]
    corner = _cell_corners(coordinates, sizes).to(coordinates.dtype)
    fraction = coordinates - corner
    scale = 2.0 / (size - 1)  # entries to grid_sample's [-1, 1]
    fetches = []  # per axis: (grid coordinate, weight) of the three fetches
    for axis in (0, 1):
        w0, w1, w2, w3 = _catmull_rom_weights(fraction[..., axis])
        inner = w1 + w2  # at least 1 on [0, 1]
        at = corner[..., axis] * scale - 1
        fetches.append(((at - scale, w0), (at + (w2 / inner) * scale, inner),
                        (at + 2 * scale, w3)))
    result = None
    for y, wy in fetches[1]:
        for x, wx in fetches[0]:
            value = torch.nn.functional.grid_sample(table, torch.stack([x, y], -1),
                                                    mode="bilinear", align_corners=True)
            weight = (wx * wy).unsqueeze(1)
            result = value.mul_(weight) if result is None else result.addcmul_(value, weight)
    return result.clamp_(min=0)


def _diffuse_tables(probes, probe_index, rotation, layout, dtype):
    """D over DIFFUSE_TABLE^2 normals: entries 1 to DIFFUSE_TABLE - 2 span each sample's table
    range, and one entry of margin on each side (see _Layout): (B, 3, N, N)."""
    batch = probe_index.shape[0]
    k = torch.arange(DIFFUSE_TABLE, dtype=dtype, device=probe_index.device)
    span = (layout.size - 1).to(dtype) * layout.step.to(dtype)[:, None]
    low = layout.origin.to(dtype) * layout.step.to(dtype)[:, None]
    fraction = (k - 1) / (DIFFUSE_TABLE - 3)
    px = low[:, 0, None] + span[:, 0, None] * fraction  # (B, N)
    py = low[:, 1, None] + span[:, 1, None] * fraction
    p = torch.stack(torch.broadcast_tensors(px[:, None, :], py[:, :, None]), -1)
    normals = inverse_stereographic(p).reshape(batch, -1, 3)
    energy, directions = probes.blocks(int(block_size(DIFFUSE_BLOCK_ANGLE, probes.height)))
    directions = rotate_z(directions[probe_index].to(dtype), rotation)
    cosines = torch.relu(normals @ directions.transpose(1, 2))
    table = cosines @ energy[probe_index].to(dtype) / math.pi
    return table.transpose(1, 2).reshape(batch, 3, DIFFUSE_TABLE, DIFFUSE_TABLE)


def _splat_half_vectors(probes, probe_index, rotation, view, layout, dtype):
    """Probe energy on each sample's half-vector lattice: (B, G, G, 3), G = layout.lattice.
    Each sample uses the probe nodes of its refinement factor."""
    batch, size = probe_index.shape[0], layout.lattice
    grid = torch.zeros(batch * size * size, 3, dtype=dtype, device=view.device)
    for factor in layout.refinement[~layout.broad].unique().tolist():
        samples = ((layout.refinement == factor) & ~layout.broad).nonzero().squeeze(1)
        energy, directions = probes.nodes(factor)
        directions = rotate_z(directions.to(dtype).expand(len(samples), -1, -1),
                               rotation[samples])
        h = torch.nn.functional.normalize(directions + view[samples, None, :], dim=-1)
        lattice = stereographic(h) / layout.step[samples].to(dtype)[:, None, None] \
            - (layout.origin[samples].to(dtype) - layout.radius)[:, None, :]
        corner = torch.floor(lattice)
        frac = lattice - corner
        corner = corner.long()
        energy = energy[probe_index[samples]].to(dtype)
        first = samples[:, None] * (size * size)
        for dx in (0, 1):
            for dy in (0, 1):
                x, y = corner[..., 0] + dx, corner[..., 1] + dy
                wx = frac[..., 0] if dx else 1 - frac[..., 0]
                wy = frac[..., 1] if dy else 1 - frac[..., 1]
                inside = (x >= 0) & (x < size) & (y >= 0) & (y < size)
                index = (first + y.clamp(0, size - 1) * size + x.clamp(0, size - 1))[inside]
                grid.index_add_(0, index, (energy * (wx * wy)[..., None])[inside])
    return grid.reshape(batch, size, size, 3)


def _specular_tables(lattice_energy, view, roughness, layout, entries, probe_height, dtype):
    """S at the table entries given as (E, 3) rows (sample, y, x): (E, 3)."""
    radius, size = layout.radius, layout.lattice
    step, origin = layout.step.to(dtype), layout.origin.to(dtype)
    node_spacings = node_spacing(probe_height) / layout.refinement.to(dtype)  # (B,)
    # Every lattice vertex's half vector h, h.v and energy, gathered per stencil: (B G G, 7).
    h = _lattice_directions(origin, step, -radius, size)
    h_dot_v = (h * view[:, None, None, :]).sum(-1, keepdim=True)
    vertex = torch.cat([h, h_dot_v, lattice_energy], -1).reshape(-1, 7)

    offsets = torch.arange(-radius, radius + 1, device=view.device)
    oy, ox = (o.reshape(-1) for o in torch.meshgrid(offsets, offsets, indexing="ij"))
    disk = ox * ox + oy * oy <= radius * radius
    oy, ox = oy[disk], ox[disk]

    def chunk_values(b, y, x):
        normal = _entry_normals(layout, b, y, x, dtype)
        flat = (b[:, None] * size + y[:, None] + radius + oy) * size + x[:, None] + radius + ox
        h, h_dot_v, energy = vertex[flat].split([3, 1, 3], -1)
        cos_h = (h @ normal[:, :, None]).squeeze(-1)
        cos_o = (normal * view[b]).sum(-1, keepdim=True)
        cos_i = 2 * h_dot_v.squeeze(-1) * cos_h - cos_o
        p2 = (stereographic(normal) ** 2).sum(-1)
        lattice_spacing = 2 * step[b] / (1 + p2)  # radians, at the entry's normal
        alpha = _blur_compensated_roughness(roughness[b], node_spacings[b] ** 2 / 6,
                                            lattice_spacing ** 2 / 6)
        weight = _ward_lobe(cos_h, cos_i, alpha[:, None])
        return (weight[:, None, :] @ energy).squeeze(1)

    chunk = max(1, ENTRY_CHUNK_LANES // oy.numel())
    # The intermediates kept for the backward pass take about 80 bytes per lane: beyond
    # KEPT_LANES the chunks are recomputed in the backward pass instead (the normals of an
    # untrained network touch so many entries that keeping them outgrew 24 GiB: a metal
    # network's first step with the relit loss, batch 16). Below it nothing is recomputed
    # (recomputing every chunk cost a plastic training step 40%).
    recompute = torch.is_grad_enabled() and entries.shape[0] * oy.numel() > KEPT_LANES and any(
        t.requires_grad for t in (vertex, view, roughness))
    results = []
    for start in range(0, entries.shape[0], chunk):
        b, y, x = entries[start:start + chunk].unbind(1)
        if recompute:
            results.append(checkpoint(chunk_values, b, y, x, use_reentrant=False))
        else:
            results.append(chunk_values(b, y, x))
    return torch.cat(results) if results else lattice_energy.new_zeros(0, 3)


def _blur_compensated_roughness(alpha, light_variance, half_vector_variance=0.0):
    """The Ward alpha to evaluate a quadrature's kernel with so that the lobe it sums has the
    width of ``alpha``'s; variances per axis in radians^2, tensors broadcasting with alpha.

    A Ward lobe is close to a Gaussian of variance alpha^2 / 2 per axis in the half vector.
    Two blurs move it. Mitsuba integrates the probe's bilinear interpolant, so each node's
    light is spread over its tent, which the quadrature puts at one direction: a light spread
    of variance v moves the half vector by v / 4, so the kernel is widened by v / 2 in
    alpha^2 (``light_variance``: h^2 / 6 for nodes h apart, (b^2 + 1) h^2 / 12 for blocks of
    b x b nodes). The sharp path's bilinear splat onto the half-vector lattice blurs the half
    vector by h^2 / 6 per axis, h the lattice spacing: narrowed by twice that
    (``half_vector_variance``). Measured: the worst of 64 hard cases 46.9 -> 51.7 dB (the
    splat), d(S)/d(alpha) at alpha 0.5 on a 64-row probe 1.2% -> 0.4% from Mitsuba's (the
    tents; docs/experiments/2026-12-05-torch-renderer-accuracy.md)."""
    return torch.sqrt(alpha * alpha + light_variance / 2 - 2 * half_vector_variance)


def _entry_normals(layout, b, y, x, dtype):
    """Unit normals (E, 3) of table entries (sample b, row y, column x)."""
    p = (torch.stack([x, y], -1).to(dtype) + layout.origin[b].to(dtype)) \
        * layout.step[b].to(dtype)[:, None]
    return inverse_stereographic(p)


def _broad_specular_tables(probes, probe_index, rotation, view, roughness, layout, entries,
                           dtype):
    """S at table entries (E, 3) of broad-lobe samples: the probe's blocks weighted by the
    kernel, a block being small next to a broad lobe. Yields (entries, values (E', 3))
    per sample and chunk of entries.

    A block's light direction and half vector depend on the sample only (its probe, rotation
    and view), so the cosines of all of a sample's entries with all its blocks are two matrix
    products."""
    for sample in entries[:, 0].unique().tolist():
        energy, directions = probes.blocks(int(layout.block[sample]))
        probe = probe_index[sample]
        light = torch.nn.functional.normalize(
            rotate_z(directions[probe, None].to(dtype), rotation[sample, None])[0], dim=-1)
        v = view[sample]
        half = torch.nn.functional.normalize(light + v, dim=-1)  # (D, 3)
        nodes = int(layout.block[sample])
        alpha = _blur_compensated_roughness(
            roughness[sample], (nodes * nodes + 1) * node_spacing(probes.height) ** 2 / 12)
        rows = entries[entries[:, 0] == sample]
        chunk = max(1, ENTRY_CHUNK_LANES // directions.shape[1])
        for start in range(0, len(rows), chunk):
            part = rows[start:start + chunk]
            b, y, x = part.unbind(1)
            normal = _entry_normals(layout, b, y, x, dtype)  # (E', 3)
            weight = _ward_lobe(normal @ half.T, normal @ light.T, alpha)
            yield part, weight @ energy[probe].to(dtype)


def _touched_entries(coordinates, layout):
    """(sample, y, x) rows of the table entries that bicubic lookups at ``coordinates``
    (B, H, W, 2) touch."""
    batch, table = coordinates.shape[0], layout.table
    corner = _cell_corners(coordinates, layout.size)
    corners = torch.zeros(batch, table, table, dtype=torch.bool, device=coordinates.device)
    sample = torch.arange(batch, device=coordinates.device)[:, None, None].expand(
        corner.shape[:3])
    corners[sample, corner[..., 1], corner[..., 0]] = True
    # A lookup with its lower-left corner at entry c touches c - 1 ... c + 2 on each axis:
    # dilate the corners.
    touched = torch.zeros_like(corners)
    for dy in (-1, 0, 1, 2):
        for dx in (-1, 0, 1, 2):
            touched[:, max(dy, 0):table + min(dy, 0), max(dx, 0):table + min(dx, 0)] |= \
                corners[:, max(-dy, 0):table - max(dy, 0), max(-dx, 0):table - max(dx, 0)]
    return touched.nonzero()


def render(albedo: torch.Tensor, normal: torch.Tensor, specular: torch.Tensor,
           roughness: torch.Tensor, probes: ProbeBank, probe_index: torch.Tensor | Sequence[int],
           rotation_deg: torch.Tensor | None = None,
           view: torch.Tensor | None = None) -> torch.Tensor:
    """HDR radiance (B, 3, H, W) of reduced SVBRDFs under rotated probes.

    albedo: (B, 3, H, W) diffuse albedo, linear RGB. normal: (B, 3, H, W) tangent-space
    normals (normalized here). specular: (B, 3) linear RGB. roughness: (B,) Ward alpha.
    probes: a ProbeBank; probe_index: (B,) long. rotation_deg: (B,) degrees about +z
    (default 0). view: (B, 3) unit directions toward the camera, z > 0 (default +z).
    """
    _check_inputs(albedo, normal, specular, roughness, probes, probe_index)
    batch, _, height, width = albedo.shape
    dtype, device = albedo.dtype, albedo.device
    probe_index = torch.as_tensor(probe_index, device=device).long()
    rotation = (torch.zeros(batch, dtype=dtype, device=device) if rotation_deg is None
                else torch.as_tensor(rotation_deg, dtype=dtype, device=device))
    view = (torch.tensor([0.0, 0.0, 1.0], dtype=dtype, device=device).expand(batch, 3)
            if view is None else torch.nn.functional.normalize(
                torch.as_tensor(view, dtype=dtype, device=device), dim=-1))
    roughness = roughness.reshape(batch)
    unit_normal = torch.nn.functional.normalize(normal, dim=1)
    p = stereographic(unit_normal.permute(0, 2, 3, 1))  # (B, H, W, 2)
    layout = _Layout(p, roughness, probes.height)

    coordinates = _table_coordinates(p, layout.step, layout.origin)
    diffuse_table = _diffuse_tables(probes, probe_index, rotation, layout, dtype)
    diffuse_coordinates = 1 + coordinates * (
        (DIFFUSE_TABLE - 3) / (layout.size - 1).to(dtype))[:, None, None, :]
    diffuse = _lookup(diffuse_table, diffuse_coordinates,
                      torch.full_like(layout.size, DIFFUSE_TABLE))

    table = torch.zeros(batch, layout.table, layout.table, 3, dtype=dtype, device=device)
    entries = _touched_entries(coordinates, layout)
    broad = layout.broad[entries[:, 0]]
    sharp = entries[~broad]
    if len(sharp):
        lattice_energy = _splat_half_vectors(probes, probe_index, rotation, view, layout, dtype)
        values = _specular_tables(lattice_energy, view, roughness, layout, sharp,
                                  probes.height, dtype)
        table = table.index_put((sharp[:, 0], sharp[:, 1], sharp[:, 2]), values)
    for part, values in _broad_specular_tables(probes, probe_index, rotation, view, roughness,
                                               layout, entries[broad], dtype):
        table = table.index_put((part[:, 0], part[:, 1], part[:, 2]), values)
    glossy = _lookup(table.permute(0, 3, 1, 2), coordinates, layout.size)

    cos_o = (unit_normal * view[:, :, None, None]).sum(1, keepdim=True)
    facing = cos_o > 0
    view_factor = torch.where(facing, cos_o, torch.ones_like(cos_o)).rsqrt()
    return torch.where(facing, albedo * diffuse + specular[:, :, None, None] * glossy
                       * view_factor, torch.zeros_like(albedo))


def _check_inputs(albedo, normal, specular, roughness, probes, probe_index):
    if albedo.ndim != 4 or albedo.shape[1] != 3:
        raise ValueError(f"albedo must be (B, 3, H, W), got shape {tuple(albedo.shape)}")
    batch = albedo.shape[0]
    if normal.shape != albedo.shape:
        raise ValueError(f"normal must have the albedo's shape {tuple(albedo.shape)}, got "
                         f"{tuple(normal.shape)}")
    if specular.shape != (batch, 3):
        raise ValueError(f"specular must be ({batch}, 3), got shape {tuple(specular.shape)}")
    if roughness.numel() != batch:
        raise ValueError(f"roughness must hold {batch} values, got shape "
                         f"{tuple(roughness.shape)}")
    low, high = ALPHA_RANGE
    alpha = roughness.detach()
    if not (torch.isfinite(alpha).all() and (alpha >= low * (1 - 1e-4)).all()
            and (alpha <= high * (1 + 1e-4)).all()):
        raise ValueError(f"Ward roughness must lie in [{low}, {high}], got values from "
                         f"{alpha.min().item():.4g} to {alpha.max().item():.4g}")
    index = torch.as_tensor(probe_index)
    if index.shape != (batch,) or (index < 0).any() or (index >= len(probes)).any():
        raise ValueError(f"probe_index must be ({batch},) indices into a bank of {len(probes)} "
                         f"probes, got {index.tolist()}")


def sphere_normals(size: int, dtype: torch.dtype = torch.float32,
                   device: str | torch.device = "cpu") -> tuple[torch.Tensor, torch.Tensor]:
    """Normals (3, size, size) of a sphere seen from +z filling the image, and its mask
    (1, size, size); outside the sphere the normal is +z and the mask 0."""
    coords = (torch.arange(size, dtype=dtype, device=device) + 0.5) / size * 2 - 1
    y, x = torch.meshgrid(-coords, coords, indexing="ij")
    r2 = x * x + y * y
    mask = (r2 < 1).to(dtype)
    z = torch.sqrt(torch.clamp(1 - r2, min=0))
    normal = torch.stack([x * mask, y * mask, z * mask + (1 - mask)])
    return normal, mask[None]
