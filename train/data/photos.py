"""Photos as network input: reading, linearizing, cropping and resizing.

The rule (the same for unlabeled training photos and for ``sa-estimate``):
1. Read the file (render.common.images.read_image: PNG, JPEG, TIFF, BMP, EXR, HDR). Grayscale photos
   are repeated to RGB.
2. Linearize. 8- and 16-bit files are taken as gamma-encoded and decoded with gamma 2.2, as the
   paper does for photos that are not radiometrically linear. EXR and HDR files are linear
   radiance of any scale: they are auto-exposed like the rendered training images
   (mean Rec. 709 luminance 0.18, render.common.exposure).
3. Crop the centred square of the shorter side, and resize it to ``size`` x ``size`` (box
   filter when shrinking, bilinear when enlarging).
4. Clamp to [0, 1].
The result is (3, size, size) float32 linear RGB, the layout of the network input.

``read_linear_photo`` stops after step 2 (the whole photo, for full-resolution maps,
train.estimation.full_resolution); ``network_view`` does steps 3 and 4 on pixels already read.
``read_photo`` and ``read_linear_photo`` refuse photos with a side under MIN_PHOTO_SIDE pixels
or a side ratio above MAX_PHOTO_ASPECT (a panorama is not a photo of a flat sample, and the
centre square would see a sliver of it); render.common.images.read_image refuses images above
its pixel limit before decoding them.
"""

from pathlib import Path

import numpy as np

from render.common.errors import InputError
from render.common.exposure import expose_numpy
from render.common.images import is_hdr, read_image, resize

PHOTO_GAMMA = 2.2
MIN_PHOTO_SIDE = 16
MAX_PHOTO_ASPECT = 4.0
"""Largest ratio of a photo's longer side to its shorter side."""


def read_photo(path: str | Path, size: int) -> np.ndarray:
    """(3, size, size) float32 linear RGB in [0, 1], by the rule in the module docstring."""
    return network_view(read_linear_photo(path), size)


def network_view(pixels: np.ndarray, size: int) -> np.ndarray:
    """Steps 3 and 4 of the rule: (H, W, 3) linear pixels -> (3, size, size), the centred
    square resized and clamped to [0, 1], channels first."""
    square = np.clip(resize(centre_square(pixels), size, size), 0, 1)
    return np.ascontiguousarray(square.transpose(2, 0, 1))


def read_linear_photo(path: str | Path) -> np.ndarray:
    """The whole photo as (H, W, 3) float32 linear RGB (steps 1 and 2 of the rule; not
    clamped)."""
    pixels = read_image(path)
    problem = photo_problem(pixels)
    if problem:
        raise InputError(path, problem)
    if pixels.shape[2] == 1:
        pixels = np.repeat(pixels, 3, axis=2)
    if is_hdr(path):
        try:
            pixels, _ = expose_numpy(np.maximum(pixels, 0.0))
        except ValueError as error:
            raise InputError(path, str(error)) from None
    else:
        pixels = pixels ** PHOTO_GAMMA
    return pixels


def photo_problem(pixels: np.ndarray) -> str | None:
    """Why (H, W, C) pixels are not a photo to estimate, in one line (a side under
    MIN_PHOTO_SIDE, a side ratio above MAX_PHOTO_ASPECT, NaN or infinite values), or None.
    The rule of read_linear_photo and of arrays given to train.estimation.Estimator."""
    height, width = pixels.shape[:2]
    if min(height, width) < MIN_PHOTO_SIDE:
        return (f"photo is {width}x{height} pixels; at least {MIN_PHOTO_SIDE}x{MIN_PHOTO_SIDE} "
                "is needed")
    if max(height, width) > MAX_PHOTO_ASPECT * min(height, width):
        return (f"photo is {width}x{height} pixels, a side ratio of "
                f"{max(height, width) / min(height, width):.1f}:1; at most "
                f"{MAX_PHOTO_ASPECT:g}:1 is accepted (a panorama is not a photo of a flat sample)")
    if not np.isfinite(pixels).all():
        return "photo has NaN or infinite pixels"
    return None


def centre_square(pixels: np.ndarray) -> np.ndarray:
    """The centred square of the shorter side of (H, W, C) pixels."""
    height, width = pixels.shape[:2]
    side = min(height, width)
    top, left = (height - side) // 2, (width - side) // 2
    return pixels[top:top + side, left:left + side]
