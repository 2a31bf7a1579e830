"""Reading and writing images with clear errors.

Arrays are float32, layout (H, W, C), row 0 at the top of the picture. 8- and 16-bit files
(PNG, JPEG, TIFF, BMP) are returned as stored, scaled to [0, 1] (no transfer function is
applied here); OpenEXR and Radiance ``.hdr`` files are returned as stored (linear radiance or
linear data); ``resize`` resamples them. Every failure raises ``InputError`` naming the file,
including an image above MAX_IMAGE_PIXELS, refused from its header before it is decoded (LDR
and OpenEXR files; Radiance ``.hdr`` files are decoded by Mitsuba without that check).
"""

from pathlib import Path

import numpy as np
import OpenEXR
from PIL import Image

from render.common.atomic_files import atomic_path
from render.common.color import to_png_bytes
from render.common.errors import InputError, require_file

LDR_SUFFIXES = {".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp"}
HDR_SUFFIXES = {".exr", ".hdr"}
IMAGE_SUFFIXES = LDR_SUFFIXES | HDR_SUFFIXES
MAX_IMAGE_PIXELS = 200_000_000
"""Largest image read (width x height): 2.4 GB as float32 RGB, twice a 100 MP photo."""
Image.MAX_IMAGE_PIXELS = None  # Pillow's own limit gives way to MAX_IMAGE_PIXELS (read_image)


def is_hdr(path: str | Path) -> bool:
    return Path(path).suffix.lower() in HDR_SUFFIXES


def read_image(path: str | Path) -> np.ndarray:
    """Read an image file as float32 (H, W, C) with C in {1, 3}; alpha is dropped."""
    path = require_file(path, "image")
    suffix = path.suffix.lower()
    if suffix == ".exr":
        pixels = _read_exr(path)
    elif suffix == ".hdr":
        pixels = _read_radiance_hdr(path)
    elif suffix in LDR_SUFFIXES:
        pixels = _read_ldr(path)
    else:
        raise InputError(path, f"unsupported image format '{suffix}'")
    if pixels.ndim == 2:
        pixels = pixels[..., None]
    if pixels.shape[2] in (2, 4):  # gray+alpha, RGB+alpha
        pixels = pixels[..., :-1]
    if pixels.shape[2] not in (1, 3) or min(pixels.shape[:2]) < 1:
        raise InputError(path, f"unexpected image shape {pixels.shape}")
    return np.ascontiguousarray(pixels, dtype=np.float32)


def _read_ldr(path):
    try:
        with Image.open(path) as image:
            _require_pixel_count(path, *image.size)
            image.load()
            if image.mode == "P":
                image = image.convert("RGBA")
            if image.mode in ("I", "I;16", "I;16B", "I;16L"):  # 16-bit files
                return np.asarray(image, dtype=np.float32) / 65535.0
            if image.mode not in ("L", "LA", "RGB", "RGBA"):
                image = image.convert("RGB")
            return np.asarray(image, dtype=np.float32) / 255.0
    except (OSError, ValueError, SyntaxError) as error:
        raise InputError(path, f"cannot decode image ({_first_line(error)})") from None


def _require_pixel_count(path, width, height):
    if width * height > MAX_IMAGE_PIXELS:
        raise InputError(path, f"image is {width}x{height} pixels "
                               f"({width * height / 1e6:.0f} MP); at most "
                               f"{MAX_IMAGE_PIXELS / 1e6:.0f} MP is read")


def _read_exr(path):
    try:
        with OpenEXR.File(str(path), header_only=True) as exr:
            low, high = exr.header()["dataWindow"]
        _require_pixel_count(path, int(high[0] - low[0] + 1), int(high[1] - low[1] + 1))
        with OpenEXR.File(str(path)) as exr:
            channels = exr.parts[0].channels
            if "RGB" in channels or "RGBA" in channels:
                return np.asarray(channels.get("RGB", channels.get("RGBA")).pixels, np.float32)
            for names in (("R", "G", "B"), ("Y",), ("R",)):
                if all(name in channels for name in names):
                    return np.stack([np.asarray(channels[n].pixels, np.float32) for n in names], -1)
            raise InputError(path, f"no RGB or Y channels (has {sorted(channels)})")
    except InputError:
        raise
    except Exception as error:  # OpenEXR raises RuntimeError/OSError/ValueError variously
        raise InputError(path, f"cannot read OpenEXR file ({_first_line(error)})") from None


def _read_radiance_hdr(path):
    """Radiance RGBE, decoded by Mitsuba's Bitmap (any variant can read files)."""
    import mitsuba as mi

    if mi.variant() is None:
        mi.set_variant("scalar_rgb")
    try:
        return np.array(mi.Bitmap(str(path)), dtype=np.float32)
    except Exception as error:
        raise InputError(path, f"cannot read Radiance HDR file ({_first_line(error)})") from None


def _first_line(error):
    text = str(error).strip().splitlines()
    return text[-1].strip() if text else type(error).__name__


def write_exr(path: str | Path, pixels: np.ndarray) -> None:
    """Write float32 (H, W, 3) or (H, W) pixels as a ZIP-compressed OpenEXR file, atomically."""
    pixels = np.ascontiguousarray(pixels, dtype=np.float32)
    channels = {"RGB": pixels} if pixels.ndim == 3 else {"Y": pixels}
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with atomic_path(path) as tmp:
        with OpenEXR.File(header, channels) as exr:
            try:
                exr.write(str(tmp))
            except RuntimeError as error:  # how OpenEXR reports a failed write (disk full)
                raise OSError(_first_line(error)) from None


def write_png(path: str | Path, linear_rgb: np.ndarray) -> None:
    """Write linear RGB in [0, 1] (H, W, 3) as an 8-bit sRGB PNG, atomically."""
    with atomic_path(path) as tmp:
        Image.fromarray(to_png_bytes(linear_rgb)).save(tmp, format="PNG")


def resize(pixels: np.ndarray, height: int, width: int) -> np.ndarray:
    """(H, W, C) float pixels to (height, width, C) float32: box filter when the pixel count
    shrinks (pixel areas averaged), bilinear otherwise."""
    shrinking = height * width < pixels.shape[0] * pixels.shape[1]
    method = Image.Resampling.BOX if shrinking else Image.Resampling.BILINEAR
    return np.stack([np.asarray(Image.fromarray(np.ascontiguousarray(pixels[..., c], np.float32))
                                .resize((width, height), method))
                     for c in range(pixels.shape[2])], -1)
