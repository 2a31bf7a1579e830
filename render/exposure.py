"""Auto-exposure and clamping: the camera model that turns an HDR render into the network input.

Exposure scales the HDR image so that its mean Rec. 709 luminance equals ``key`` (average
metering, like a camera's; 0.18 is photographic middle gray in linear terms), then clamps to
[0, 1]. The rule is scale invariant: multiplying the HDR image (or both relative albedos) by
any factor gives the same exposed image, which is why relative albedos can be rendered directly.
"""

import numpy as np

from render.color import luminance

DEFAULT_KEY = 0.18


def exposure_scale(hdr, key=DEFAULT_KEY):
    """Factor that maps the mean luminance of ``hdr`` (H, W, 3), linear RGB, to ``key``."""
    mean = float(luminance(hdr).mean())
    if not np.isfinite(mean) or mean <= 0:
        raise ValueError(f"cannot expose an image of mean luminance {mean}")
    return key / mean


def expose(hdr, key=DEFAULT_KEY):
    """(exposed image clamped to [0, 1], float32; the exposure scale used)."""
    scale = exposure_scale(hdr, key)
    return np.clip(hdr * scale, 0.0, 1.0).astype(np.float32), scale
