"""The albedo correction (train.networks.svbrdf_net.AlbedoCorrection), its fit
(train.fits.albedo_correction) and its full-resolution maps (train.estimation.full_resolution)."""

import copy
import dataclasses
import json

import numpy as np
import pytest
import torch
from safetensors.torch import load_file, save_file
from torch.nn import functional

from render.common.errors import InputError
from render.common.images import resize
from render.common.probes import find_probes, load_probe
from render.torch_renderer.renderer import ProbeBank
from tests.conftest import BUNDLED_MATERIALS, BUNDLED_PROBES
from train.data.photos import read_linear_photo
from train.estimation.full_resolution import full_resolution_maps
from train.fits.albedo_correction import FitConfig, albedo_rmse, check_errors, fit
from train.fits.part_fitting import fit_part_onto_model
from train.networks.model_files import FORMAT, load_network, model_metadata, save_model
from train.networks.svbrdf_net import AlbedoCorrection, NetworkConfig, SVBRDFNet

BUNDLED_PHOTO = "scenes/photos/brick-reference-01.jpg"
TINY_CORRECTED = NetworkConfig(input_size=32, width=4, max_width=16, levels=3, hidden=32,
                               albedo_network="photo-affine", albedo_correction=True)


@pytest.fixture(scope="module")
def bank():
    return ProbeBank([load_probe(path).radiance for path in find_probes(BUNDLED_PROBES)])


def a_trained_correction(net):
    """Give ``net``'s correction a gain that varies with the albedo (as a fit would)."""
    torch.manual_seed(1)
    with torch.no_grad():
        net.correction.log_gain_output.weight.normal_(0.0, 0.3)
        net.correction.log_gain_output.bias.copy_(torch.tensor([0.2, 0.0, -0.2]))


def test_the_correction_needs_the_photo_affine_albedo_network():
    with pytest.raises(ValueError, match="photo-affine"):
        NetworkConfig(albedo_correction=True)


def test_a_fresh_correction_is_the_identity():
    torch.manual_seed(0)
    net = SVBRDFNet(TINY_CORRECTED).eval()
    plain = SVBRDFNet(dataclasses.replace(TINY_CORRECTED, albedo_correction=False)).eval()
    plain.load_state_dict({name: value for name, value in net.state_dict().items()
                           if not name.startswith("correction.")})
    image = torch.rand(2, 3, 32, 32)
    with torch.no_grad():
        a, b = plain(image), net(image)
    for name in a:
        assert torch.allclose(a[name], b[name], atol=1e-6), name


def test_the_corrected_albedo_is_the_gain_times_the_albedo_at_mean_one_half():
    torch.manual_seed(0)
    net = SVBRDFNet(TINY_CORRECTED).eval()
    a_trained_correction(net)
    image = torch.rand(2, 3, 32, 32)
    with torch.no_grad():
        albedo = net(image)["albedo"]
        uncorrected = net.photo_affine_albedo(image, image)
        gain = torch.exp(net.correction.log_gain(uncorrected))
    expected = uncorrected * gain
    expected = expected * (0.5 / expected.mean((1, 2, 3), keepdim=True))
    assert torch.allclose(albedo, expected, rtol=1e-5, atol=1e-6)
    assert torch.allclose(albedo.mean((1, 2, 3)), torch.full((2,), 0.5), atol=1e-5)
    assert (albedo - uncorrected).abs().mean() > 0.02
    assert gain.std() > 0.01  # a gain per pixel, not one factor


def test_a_model_file_keeps_the_correction(tmp_path):
    torch.manual_seed(0)
    net = SVBRDFNet(TINY_CORRECTED).eval()
    a_trained_correction(net)
    path = tmp_path / "m.safetensors"
    save_model(net, path, {"class": "plastic"})
    loaded = load_network(path)
    assert loaded.config.albedo_correction
    assert isinstance(loaded.correction, AlbedoCorrection)
    image = torch.rand(1, 3, 32, 32)
    with torch.no_grad():
        a, b = net(image)["albedo"], loaded(image)["albedo"]
    assert torch.allclose(a, b, rtol=1e-2, atol=1e-2)  # float16 weights in the file


def test_a_square_photo_at_input_size_maps_as_the_estimate():
    torch.manual_seed(0)
    net = SVBRDFNet(TINY_CORRECTED).eval()
    a_trained_correction(net)
    photo = resize(read_linear_photo(BUNDLED_PHOTO), 32, 32).clip(0.0, 1.0)
    albedo, _ = full_resolution_maps(net, photo, max_side=32)
    with torch.no_grad():
        estimate = net(torch.as_tensor(photo.transpose(2, 0, 1))[None])["albedo"]
    assert np.allclose(albedo, estimate[0].permute(1, 2, 0).numpy(), rtol=1e-4, atol=1e-5)


def test_a_larger_photo_takes_the_gain_read_at_the_networks_scale():
    """The full-resolution albedo is the photo-affine one times the overview's gain,
    upsampled: not the gain the correction would read at full resolution."""
    torch.manual_seed(0)
    net = SVBRDFNet(TINY_CORRECTED).eval()
    a_trained_correction(net)
    photo = resize(read_linear_photo(BUNDLED_PHOTO), 64, 96).clip(0.0, 1.0)
    albedo, _ = full_resolution_maps(net, photo, max_side=96)
    image = torch.as_tensor(photo.transpose(2, 0, 1))[None]
    overview = torch.as_tensor(resize(photo, 32, 48).transpose(2, 0, 1))[None]
    view = torch.as_tensor(resize(photo[:, 16:80], 32, 32).transpose(2, 0, 1))[None]
    with torch.no_grad():
        uncorrected = net.photo_affine_albedo(image, view)
        gain = functional.interpolate(
            net.correction.log_gain(net.photo_affine_albedo(overview, view)), size=(64, 96),
            mode="bilinear", align_corners=False).exp()
        at_full_resolution = net.correction(uncorrected)
    expected = uncorrected * gain
    expected = (expected * (0.5 / expected.mean()))[0].permute(1, 2, 0).numpy()
    assert albedo.shape == (64, 96, 3)
    assert np.allclose(albedo, expected, rtol=1e-4, atol=1e-5)
    assert np.abs(albedo - at_full_resolution[0].permute(1, 2, 0).numpy()).mean() > 1e-3


def test_fitting_lowers_the_kept_out_albedo_error_and_resumes(tmp_path, bank):
    torch.manual_seed(0)
    frozen = SVBRDFNet(TINY_CORRECTED).eval()
    net = copy.deepcopy(frozen)
    cfg = FitConfig(work=str(tmp_path / "a"), maps=str(BUNDLED_MATERIALS), photos=40,
                    steps=300, learning_rate=3e-3, halvings=(200,))
    report = fit(cfg, net, bank)
    assert report["check_photos"] == 4
    assert report["check_albedo_rmse_after"] < 0.9 * report["check_albedo_rmse_before"]
    assert (tmp_path / "a" / "fit.png").stat().st_size > 1000
    prepared = torch.load(tmp_path / "a" / "prepared.pt", weights_only=True)["data"]
    assert prepared["estimate"].shape == prepared["truth"].shape == (40, 3, 32, 32)
    after, before = check_errors(net.correction, prepared, torch.arange(36))  # fitted photos
    assert after < 0.8 * before
    # a fit cut off at step 150 and run again to 300 ends where the uncut one did
    cut = dataclasses.replace(cfg, work=str(tmp_path / "b"))
    fit(dataclasses.replace(cut, steps=150), copy.deepcopy(frozen), bank)
    resumed = copy.deepcopy(frozen)
    fit(cut, resumed, bank)
    for name, value in net.correction.state_dict().items():
        assert torch.allclose(resumed.correction.state_dict()[name], value, atol=1e-6), name
    with pytest.raises(ValueError, match="more than"):
        fit(dataclasses.replace(cut, steps=100), resumed, bank)


def test_albedo_rmse_by_hand():
    albedo = torch.zeros(2, 3, 4, 4)
    truth = torch.zeros(2, 3, 4, 4)
    truth[0] = 0.5
    truth[1, 0, :2] = 1.0  # a sixth of the values off by 1
    assert torch.allclose(albedo_rmse(albedo, truth), torch.tensor([0.5, (1 / 6) ** 0.5]))


def test_a_fit_onto_a_model_file_writes_the_model_with_its_correction(tmp_path, bank):
    torch.manual_seed(0)
    plain = SVBRDFNet(dataclasses.replace(TINY_CORRECTED, albedo_correction=False)).eval()
    save_model(plain, tmp_path / "plain.safetensors", {"class": "plastic", "recipe": "stages"})
    cfg = FitConfig(work=str(tmp_path / "work"), maps=str(BUNDLED_MATERIALS), photos=20,
                    steps=10)
    report = fit_part_onto_model(tmp_path / "plain.safetensors", tmp_path / "out.safetensors",
                                 "albedo_correction", BUNDLED_PROBES,
                                 lambda net, bank: fit(cfg, net, bank), "the fit's command")
    metadata = model_metadata(tmp_path / "out.safetensors", FORMAT, "model")
    assert metadata["recipe"] == "stages; then the fit's command"
    assert metadata["class"] == "plastic"
    assert json.loads(metadata["albedo_correction_fit"]) == report
    loaded = load_network(tmp_path / "out.safetensors")
    assert loaded.config.albedo_correction
    image = torch.rand(1, 3, 32, 32)
    with torch.no_grad():  # the networks as they were
        assert torch.allclose(loaded(image)["normal"], plain(image)["normal"], atol=1e-2)


def test_a_fit_onto_a_map_albedo_model_is_refused(tmp_path):
    torch.manual_seed(0)
    config = dataclasses.replace(TINY_CORRECTED, albedo_network="map", albedo_correction=False)
    save_model(SVBRDFNet(config), tmp_path / "map.safetensors", {})
    with pytest.raises(InputError, match="map.safetensors.*photo-affine"):
        fit_part_onto_model(tmp_path / "map.safetensors", tmp_path / "out.safetensors",
                            "albedo_correction", BUNDLED_PROBES, None, "")
    assert not (tmp_path / "out.safetensors").exists()


def test_a_model_file_without_its_correction_weights_is_refused_by_name(tmp_path):
    """A file whose configuration has a correction but whose weights lack it."""
    torch.manual_seed(0)
    plain = SVBRDFNet(dataclasses.replace(TINY_CORRECTED, albedo_correction=False))
    save_model(plain, tmp_path / "m.safetensors", {})
    metadata = model_metadata(tmp_path / "m.safetensors", FORMAT, "model")
    metadata["network"] = json.dumps(vars(TINY_CORRECTED))
    save_file(load_file(str(tmp_path / "m.safetensors")), str(tmp_path / "m.safetensors"),
              metadata=metadata)
    with pytest.raises(InputError, match=r"m.safetensors.*do not fit.*missing "
                                         r"correction\.first\.weight, .* and 12 more"):
        load_network(tmp_path / "m.safetensors")
