"""Albedo and normal maps over the whole photo at its own resolution (``sa-estimate``'s maps).

The network's estimate (train.estimation.estimator.estimate) sees the photo's centre square at S x S
pixels (S, the network's input size), the scale it was trained on. The map networks are fully
convolutional, so they can also run on other sizes; the maps here come from two runs:

1. **Overview**: the whole photo resized so that its shorter side is S (the longer side rounded
   to a multiple of 2^levels), run in one piece. It sees the texture at the training scale;
   for a square photo it is exactly the network's S x S estimate.
2. **Detail**: the photo at output resolution (its own, the longer side reduced to at most
   ``max_side``), cut into S x S tiles that overlap by ``overlap`` pixels (at most S / 4),
   each run alone (in
   batches: memory grows with the batch, not with the photo) and blended with weights that
   fall linearly towards each tile's edge (normalized by their sum, so no seam).
3. **Combined**: the detail maps give the high frequencies, the overview the low ones:
   albedo = detail x up(overview) / up(down(detail)) per channel, normals =
   normalize(detail - up(down(detail)) + up(overview)), where down is an area average to the
   overview's size and up is bilinear. So the maps, averaged down to the overview's size,
   agree with the overview.

A photo-affine albedo network (train.networks.svbrdf_net.PhotoAffineAlbedoNet) needs none of
this: its albedo is the photo less an offset, pixel by pixel, so the whole photo at output
resolution loses the offset predicted for its network-size view (the centre square at S x S,
as the estimate sees it); only the normals go through steps 1 to 3. For a square photo of
S x S pixels, this is the network-size estimate's albedo.

Why not the tiles alone: a tile sees the texture magnified (output side / S times), a scale
the networks were not trained on, and each tile's albedo comes out relative to its own content
(mean about 0.5 per tile), which would make tiles of a dark and a light region equally bright.
The combination keeps the tiles' fine detail and the overview's large-scale values.

Conventions: photos (H, W, 3) linear RGB; maps (H, W, 3) float32, albedo relative (the
overview's scale), normals unit tangent-space vectors (docs/conventions.md).
"""

import math

import numpy as np
import torch
from torch.nn import functional

from render.common.images import resize
from train.data.photos import network_view
from train.networks.svbrdf_net import SVBRDFNet, decode_normal

MAX_SIDE = 2048
"""Default longest side of the full-resolution maps (px)."""
TILE_OVERLAP = 64
"""Overlap of neighbouring detail tiles (px)."""
TILE_BATCH = 4
"""Detail tiles run together."""


def full_resolution_maps(net: SVBRDFNet, linear_photo: np.ndarray, max_side: int = MAX_SIDE,
                         overlap: int = TILE_OVERLAP) -> tuple[np.ndarray, np.ndarray]:
    """(albedo, normal), each (H', W', 3) float32, of ``linear_photo`` (H, W, 3) by the
    module docstring's rule; (H', W') is (H, W) scaled so that the longer side is at most
    ``max_side``."""
    config = net.config
    height, width = linear_photo.shape[:2]
    scale = min(1.0, max_side / max(height, width))
    out_height, out_width = max(1, round(height * scale)), max(1, round(width * scale))
    photo = np.clip(resize(linear_photo, out_height, out_width), 0.0, 1.0)
    with torch.no_grad():
        overview = map_networks(net, overview_photo(photo, config.input_size,
                                                     2 ** config.levels)[None])
        detail = tiled_map_networks(net, photo, config.input_size, overlap)
        maps = combine(overview, detail)
        if "albedo" not in maps:  # a photo-affine albedo network
            maps["albedo"] = photo_affine_albedo_map(net, photo)
    return tuple(np.ascontiguousarray(maps[name][0].permute(1, 2, 0).numpy())
                 for name in ("albedo", "normal"))


def photo_affine_albedo_map(net: SVBRDFNet, photo: np.ndarray) -> torch.Tensor:
    """(1, 3, H, W): the (H, W, 3) photo's albedo by a photo-affine albedo network, its
    offset read on the photo's network-size view (its centre square at S x S)."""
    device = next(net.parameters()).device
    image = torch.as_tensor(np.ascontiguousarray(photo.transpose(2, 0, 1)))[None].to(device)
    view = torch.as_tensor(network_view(photo, net.config.input_size))[None].to(device)
    return net.albedo(image, reference=view).cpu()


def overview_photo(photo: np.ndarray, input_size: int, multiple: int) -> np.ndarray:
    """(H, W, 3) -> (h, w, 3): the shorter side ``input_size``, the longer one in proportion,
    rounded to a multiple of ``multiple``."""
    height, width = photo.shape[:2]
    scale = input_size / min(height, width)
    sides = [max(multiple, round(side * scale / multiple) * multiple) for side in (height, width)]
    return np.clip(resize(photo, *sides), 0.0, 1.0)


def map_networks(net: SVBRDFNet, photos: np.ndarray) -> dict[str, torch.Tensor]:
    """(B, H, W, 3) photos, sides multiples of 2^levels -> dict of the maps of the U-Net
    networks, each (B, 3, H, W) on the CPU: normal, and albedo unless the albedo network is
    photo-affine (whose albedo photo_affine_albedo_map makes)."""
    device = next(net.parameters()).device
    image = torch.as_tensor(np.ascontiguousarray(photos.transpose(0, 3, 1, 2))).to(device)
    maps = {"normal": decode_normal(net.normal(image)).cpu()}
    if net.config.albedo_network == "map":
        maps["albedo"] = net.albedo(image).cpu()
    return maps


def tile_starts(length: int, tile: int, overlap: int) -> list[int]:
    """First pixels of the tiles covering [0, length) with at least ``overlap`` pixels shared
    by neighbours, spread evenly; ``length`` >= ``tile`` > ``overlap``."""
    if not length >= tile > overlap >= 0:
        raise ValueError(f"no tiling of {length} px by {tile} px tiles overlapping {overlap} px")
    count = 1 if length <= tile else math.ceil((length - overlap) / (tile - overlap))
    if count == 1:
        return [0]
    return [round(i * (length - tile) / (count - 1)) for i in range(count)]


def tile_weight(tile: int, overlap: int) -> np.ndarray:
    """(tile,) blending weights: rising linearly over ``overlap`` pixels from each edge to 1,
    never 0 (so a photo border, covered by one tile, keeps its pixels)."""
    ramp = np.minimum(np.arange(1, tile + 1), np.arange(tile, 0, -1)) / (overlap + 1)
    return np.minimum(ramp, 1.0).astype(np.float32)


def tiled_map_networks(net: SVBRDFNet, photo: np.ndarray, tile: int,
                       overlap: int) -> dict[str, torch.Tensor]:
    """The maps of map_networks, each (1, 3, H, W), of the (H, W, 3) photo run as overlapping
    ``tile`` x ``tile`` tiles, blended (a photo side under ``tile`` is padded by reflection
    and the padding cut off again)."""
    overlap = min(overlap, tile // 4)
    height, width = photo.shape[:2]
    padded = np.pad(photo, ((0, max(0, tile - height)), (0, max(0, tile - width)), (0, 0)),
                    mode="reflect")
    rows, columns = (tile_starts(side, tile, overlap) for side in padded.shape[:2])
    weight = torch.as_tensor(np.outer(tile_weight(tile, overlap), tile_weight(tile, overlap)))
    total = torch.zeros(padded.shape[:2])
    sums = {}
    corners = [(top, left) for top in rows for left in columns]
    for first in range(0, len(corners), TILE_BATCH):
        batch = corners[first:first + TILE_BATCH]
        images = np.stack([padded[t:t + tile, l:l + tile] for t, l in batch])
        maps = map_networks(net, images)
        for i, (top, left) in enumerate(batch):
            window = (slice(top, top + tile), slice(left, left + tile))
            total[window] += weight
            for name, tiles in maps.items():
                accumulated = sums.setdefault(name, torch.zeros((3,) + padded.shape[:2]))
                accumulated[(slice(None),) + window] += weight * tiles[i]
    blended = {"normal": functional.normalize(sums["normal"], dim=0)}
    if "albedo" in sums:
        blended["albedo"] = sums["albedo"] / total
    return {name: value[None, :, :height, :width] for name, value in blended.items()}


def combine(overview: dict[str, torch.Tensor],
            detail: dict[str, torch.Tensor]) -> dict[str, torch.Tensor]:
    """The maps of ``detail`` (dicts as map_networks gives) at the detail's size, with the
    detail's high frequencies and the overview's low ones (module docstring, step 3)."""
    size = detail["normal"].shape[2:]

    def low(name):
        down = functional.interpolate(detail[name], size=overview[name].shape[2:], mode="area")
        return functional.interpolate(down, size=size, mode="bilinear", align_corners=False)

    def up(name):
        return functional.interpolate(overview[name], size=size, mode="bilinear",
                                      align_corners=False)

    normal = detail["normal"] - low("normal") + up("normal")
    normal = torch.cat([normal[:, :2], normal[:, 2:].clamp(min=0.05)], 1)
    combined = {"normal": functional.normalize(normal, dim=1)}
    if "albedo" in detail:
        combined["albedo"] = detail["albedo"] * up("albedo") / low("albedo").clamp(min=1e-4)
    return combined
