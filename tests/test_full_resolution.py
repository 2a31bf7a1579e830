"""Full-resolution maps (train.full_resolution): tiles cover the photo, no seams where tiles
meet, and agreement with the network's input-size estimate."""

import numpy as np
import pytest
import torch
from torch.nn import functional

from render.common.images import resize
from tests.conftest import write_png
from train.estimate import estimate
from train.full_resolution import full_resolution_maps, tile_starts
from train.model_files import load_network, shipped_model_path
from train.photos import read_linear_photo, read_photo

BUNDLED_PHOTO = "scenes/photos/brick-reference-01.jpg"


@pytest.fixture(scope="module")
def net():
    return load_network(shipped_model_path("general"), torch.device("cpu"))


@pytest.mark.parametrize("length", [256, 300, 511, 768, 2048])
def test_tiles_cover_the_photo_and_overlap(length):
    starts = tile_starts(length, 256, 64)
    assert starts[0] == 0 and starts[-1] + 256 == length
    assert all(64 <= a + 256 - b < 256 for a, b in zip(starts, starts[1:]))


def border_to_inner_gradient(maps, starts, tile, axis):
    """Mean |difference of neighbouring pixels| across the lines where tiles begin or end,
    over the median of the same at every other line (1 = a border like any other line)."""
    gradient = np.abs(np.diff(maps, axis=axis)).mean(axis=(1 - axis, 2))
    borders = sorted({s - 1 for s in starts[1:]} | {s + tile - 1 for s in starts[:-1]})
    return gradient[borders].mean() / np.median(np.delete(gradient, borders))


def test_no_seams_where_tiles_meet(net):
    photo = resize(read_linear_photo(BUNDLED_PHOTO), 576, 768)  # 3 x 4 tiles of 256 px
    blended = full_resolution_maps(net, photo)
    hard = full_resolution_maps(net, photo, overlap=0)  # tiles side by side, not blended
    for axis, length in ((1, 768), (0, 576)):
        for name, blended_map, hard_map in zip(("albedo", "normal"), blended, hard):
            ratio = border_to_inner_gradient(blended_map, tile_starts(length, 256, 64), 256,
                                             axis)
            assert ratio < 1.5, (name, axis, ratio)
            # The measure sees seams where there are some: it can fail.
            hard_ratio = border_to_inner_gradient(hard_map, tile_starts(length, 256, 0), 256,
                                                  axis)
            assert hard_ratio > 2.0, (name, axis, hard_ratio)


def test_maps_downsampled_agree_with_the_input_size_estimate(net, tmp_path):
    square = read_linear_photo(BUNDLED_PHOTO)[:, 32:224]  # the centre 192 x 192
    write_png(tmp_path / "photo.png", resize(square, 640, 640) ** (1 / 2.2))
    albedo, normal = full_resolution_maps(net, read_linear_photo(tmp_path / "photo.png"))
    assert albedo.shape == normal.shape == (640, 640, 3)
    small = estimate(net, read_photo(tmp_path / "photo.png", 256))

    def down(image):
        return functional.interpolate(torch.as_tensor(image).permute(2, 0, 1)[None],
                                      size=(256, 256), mode="area")[0].permute(1, 2, 0).numpy()

    albedo_error = np.abs(down(albedo) - small.albedo).mean() / small.albedo.mean()
    assert albedo_error < 0.06, albedo_error
    down_normal = down(normal)
    down_normal /= np.linalg.norm(down_normal, axis=2, keepdims=True)
    angle = np.degrees(np.arccos(np.clip((down_normal * small.normal).sum(2), -1.0, 1.0)))
    assert angle.mean() < 1.0, angle.mean()


def test_maps_cover_the_whole_photo_up_to_max_side(net):
    photo = read_linear_photo(BUNDLED_PHOTO)  # 256 x 192
    albedo, normal = full_resolution_maps(net, photo, max_side=200)
    assert albedo.shape == normal.shape == (150, 200, 3)
    assert np.isfinite(albedo).all() and (albedo > 0).all()
    assert np.allclose(np.linalg.norm(normal, axis=2), 1.0, atol=1e-5)
