"""Auto-exposure and clamping: the camera model that turns an HDR render into the network input.

Exposure scales the HDR image so that its mean Rec. 709 luminance equals ``key`` (average
metering, like a camera's; 0.18 is photographic middle gray in linear terms), then clamps to
[0, 1]. The rule is scale invariant: multiplying the HDR image (or both relative albedos) by
any factor gives the same exposed image, which is why relative albedos can be rendered directly.

The rule has two forms, side by side: ``expose_numpy`` exposes one (H, W, 3) numpy image (the
dataset generator, photos) and also returns the scale it used; ``expose`` exposes a batch of
(B, 3, H, W) torch tensors (the trainer's renders) on their device and in their dtype, with
``exposure_scales`` giving their scales. The
torch form uses tensor methods only, so this module does not import torch.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from render.common.color import REC709_LUMINANCE, luminance

if TYPE_CHECKING:
    import torch

DEFAULT_KEY = 0.18


def exposure_scale(hdr: np.ndarray, key: float = DEFAULT_KEY) -> float:
    """Factor that maps the mean luminance of ``hdr`` (H, W, 3), linear RGB, to ``key``."""
    mean = float(luminance(hdr).mean())
    if not np.isfinite(mean) or mean <= 0:
        raise ValueError(f"cannot expose an image of mean luminance {mean}")
    return key / mean


def expose_numpy(hdr: np.ndarray, key: float = DEFAULT_KEY) -> tuple[np.ndarray, float]:
    """(exposed image clamped to [0, 1], float32; the exposure scale used)."""
    scale = exposure_scale(hdr, key)
    return np.clip(hdr * scale, 0.0, 1.0).astype(np.float32), scale


def exposure_scales(hdr: torch.Tensor, key: float = DEFAULT_KEY) -> torch.Tensor:
    """(B,) factors that map the mean Rec. 709 luminance of each of the (B, 3, H, W) torch
    images ``hdr`` to ``key`` (the torch form of exposure_scale). Raises ValueError where an
    image is black or not finite."""
    weights = hdr.new_tensor(REC709_LUMINANCE)
    mean = (hdr * weights[:, None, None]).sum(1).mean((1, 2))
    bad = ~(mean.isfinite() & (mean > 0))
    if bad.any():
        raise ValueError(f"cannot expose images {bad.nonzero().flatten().tolist()}: mean "
                         f"luminance {mean[bad].tolist()}")
    return key / mean


def expose(hdr: torch.Tensor, key: float = DEFAULT_KEY, reference: torch.Tensor | None = None,
           clamp: bool = True) -> torch.Tensor:
    """Auto-exposure and clamping of (B, 3, H, W) HDR torch tensors, as ``expose_numpy`` does
    to each image: each image scaled so its mean Rec. 709 luminance is ``key``, then clamped to
    [0, 1] (unless ``clamp`` is False). With ``reference`` (same shape), each image takes the
    scale that exposes its reference image instead (to compare two renders under one camera
    setting). Raises ValueError for another shape, or where a metered image is black or not
    finite."""
    metered = hdr if reference is None else reference
    if hdr.ndim != 4 or hdr.shape[1] != 3 or metered.shape != hdr.shape:
        raise ValueError(f"expose takes (B, 3, H, W) images (and a reference of their shape), "
                         f"got {tuple(hdr.shape)} and {tuple(metered.shape)}")
    exposed = hdr * exposure_scales(metered, key)[:, None, None, None]
    return exposed.clamp(0, 1) if clamp else exposed
