"""Full-resolution maps (train.estimation.full_resolution): tiles cover the photo, no seams where
tiles meet, and agreement with the network's input-size estimate."""

import numpy as np
import pytest
import torch
from torch.nn import functional

from render.common.images import resize
from tests.conftest import write_png
from train.data.photos import centre_square, read_linear_photo, read_photo
from train.estimation.estimator import estimate
from train.estimation.full_resolution import full_resolution_maps, tile_starts
from train.networks.model_files import load_network, shipped_model_path
from train.networks.svbrdf_net import NetworkConfig, SVBRDFNet, photo_affine_albedo

BUNDLED_PHOTO = "scenes/photos/brick-reference-01.jpg"


@pytest.fixture(scope="module")
def net():
    return load_network(shipped_model_path("metal"), torch.device("cpu"))


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


def test_a_photo_affine_albedo_maps_the_whole_photo_by_its_views_numbers():
    """A photo-affine albedo network maps every pixel of a non-square photo at output
    resolution by the reflection's share predicted for the photo's network-size view (its
    centre square)."""
    torch.manual_seed(0)
    config = NetworkConfig(input_size=32, width=4, max_width=16, levels=3, hidden=32,
                           albedo_network="photo-affine")
    net = SVBRDFNet(config).eval()
    with torch.no_grad():  # a clear offset, so that the map is far from the identity
        net.albedo.affine.synthesis[3].bias.copy_(torch.tensor([-0.5]))
    photo = resize(read_linear_photo(BUNDLED_PHOTO), 48, 80)
    albedo, normal = full_resolution_maps(net, photo, max_side=40)
    small = resize(photo, 24, 40)
    view = torch.as_tensor(resize(centre_square(small), 32, 32).transpose(2, 0, 1)[None])
    with torch.no_grad():
        direct = photo_affine_albedo(net.albedo.affine(view.clip(0, 1)),
                                     torch.as_tensor(small.transpose(2, 0, 1)[None]))
    assert albedo.shape == normal.shape == (24, 40, 3)
    assert np.allclose(albedo, direct[0].permute(1, 2, 0).numpy(), rtol=1e-4, atol=1e-6)
    plain = small * (0.5 / small.mean())  # the photo's own pattern: not the same map
    assert np.abs(albedo - plain).mean() > 0.05


def test_a_square_photo_at_the_input_size_gets_the_estimates_photo_affine_albedo():
    torch.manual_seed(0)
    config = NetworkConfig(input_size=32, width=4, max_width=16, levels=3, hidden=32,
                           albedo_network="photo-affine")
    net = SVBRDFNet(config).eval()
    with torch.no_grad():
        net.albedo.affine.synthesis[3].bias.copy_(torch.tensor([-0.5]))
    photo = np.clip(resize(read_linear_photo(BUNDLED_PHOTO), 32, 32), 0, 1)
    albedo, _ = full_resolution_maps(net, photo)
    estimated = estimate(net, np.ascontiguousarray(photo.transpose(2, 0, 1)))
    assert np.allclose(albedo, estimated.albedo, rtol=1e-4, atol=1e-6)
    assert np.abs(albedo - photo * (0.5 / photo.mean())).mean() > 0.02  # an offset was taken
