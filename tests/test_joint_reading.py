"""The joint reading head (train.networks.svbrdf_net.JointReading) and its fit
(train.fits.joint_reading)."""

import dataclasses
import math

import pytest
import torch

from render.common.probes import find_probes, load_probe
from render.torch_renderer.renderer import ProbeBank, render
from tests.conftest import BUNDLED_MATERIALS, BUNDLED_PROBES
from train.fits.joint_reading import (
    ALPHA_GRID,
    FitConfig,
    fit,
    flat_radiance_tables,
    relit_errors,
    specular_at,
)
from train.networks.model_files import FORMAT, load_network, model_metadata, save_model
from train.networks.svbrdf_net import (
    PHOTO_QUANTILES,
    JointReading,
    NetworkConfig,
    SVBRDFNet,
    photo_statistics,
)

TINY_AFFINE = NetworkConfig(input_size=32, width=4, max_width=16, levels=3, hidden=32,
                            albedo_network="photo-affine")
TINY_MAP = dataclasses.replace(TINY_AFFINE, albedo_network="map")


@pytest.fixture(scope="module")
def bank():
    return ProbeBank([load_probe(path).radiance for path in find_probes(BUNDLED_PROBES)])


def test_beside_a_map_albedo_network_the_head_corrects_the_homogeneous_readings_only():
    """No reflection share to read: four values, the map network's albedo as it was."""
    torch.manual_seed(0)
    net = SVBRDFNet(dataclasses.replace(TINY_MAP, joint_reading=True)).eval()
    assert not net.joint.reads_share and net.joint.values == 4
    assert net.joint.mean.shape == (4 + 3 * len(PHOTO_QUANTILES),)
    image = torch.rand(2, 3, 32, 32)
    with torch.no_grad():
        before = net(image)
        net.joint.mlp[2].bias.copy_(torch.tensor([0.5, 0.5, 0.5, -1.0]))
        after = net(image)
        albedo_alone = net(image, parts=("albedo",))
    assert torch.allclose(after["log_specular"], before["log_specular"] + 0.5, atol=1e-5)
    assert torch.allclose(after["log_roughness"], before["log_roughness"] - 1.0, atol=1e-5)
    assert torch.equal(after["albedo"], before["albedo"])
    assert torch.equal(albedo_alone["albedo"], before["albedo"])
    assert net.joint_readings(image)[2] is None


def test_a_fresh_head_is_the_identity():
    """Its last layer starts at zero: the network with a fresh head answers as without."""
    torch.manual_seed(0)
    plain = SVBRDFNet(TINY_AFFINE).eval()
    joint = SVBRDFNet(dataclasses.replace(TINY_AFFINE, joint_reading=True)).eval()
    joint.load_state_dict(plain.state_dict() | {
        f"joint.{name}": value for name, value in joint.joint.state_dict().items()})
    image = torch.rand(2, 3, 32, 32)
    with torch.no_grad():
        a, b = plain(image), joint(image)
    for name in a:
        assert torch.allclose(a[name], b[name], atol=1e-6), name


def test_a_trained_head_changes_all_three_readings():
    torch.manual_seed(0)
    net = SVBRDFNet(dataclasses.replace(TINY_AFFINE, joint_reading=True)).eval()
    image = torch.rand(1, 3, 32, 32)
    with torch.no_grad():
        before = net(image)
        net.joint.mlp[2].bias.copy_(torch.tensor([0.5, 0.5, 0.5, -1.0, 2.0]))
        after = net(image)
    assert torch.allclose(after["log_specular"], before["log_specular"] + 0.5, atol=1e-5)
    assert torch.allclose(after["log_roughness"], before["log_roughness"] - 1.0, atol=1e-5)
    # a larger reflection share (logit + 2) takes more offset away: a higher contrast
    assert after["albedo"].std() > before["albedo"].std() * 1.05


def test_photo_statistics_are_channel_quantiles_over_the_mean():
    ramp = torch.linspace(0.0, 1.0, 101)[None, None, :, None].expand(1, 3, 101, 1).clone()
    ramp[:, 1] *= 0.5
    statistics = photo_statistics(ramp).reshape(len(PHOTO_QUANTILES), 3)
    mean = float(ramp.mean())
    for q, row in zip(PHOTO_QUANTILES, statistics):
        expected = torch.tensor([q, 0.5 * q, q]) / mean
        assert torch.allclose(row, expected, atol=1e-5), q
    assert torch.allclose(photo_statistics(ramp * 7.0), photo_statistics(ramp), atol=1e-5)


def test_flat_tables_give_the_renderers_flat_sample(bank):
    """Albedo times the diffuse table plus specular albedo times the specular table is the
    torch render of a flat sample, at any rotation of the probe: on the alpha grid up to float
    rounding, between grid points with the specular part within 3% (interpolated in log
    alpha)."""
    diffuse, specular = flat_radiance_tables(bank)
    count = len(bank)
    albedo = torch.rand(count, 3, 8, 8)
    flat = torch.zeros(count, 3, 8, 8)
    flat[:, 2] = 1.0
    rho = torch.tensor([0.3, 0.2, 0.1]).expand(count, 3)
    between = math.sqrt(float(ALPHA_GRID[20] * ALPHA_GRID[21]))
    for alpha, rtol in ((float(ALPHA_GRID[8]), 2e-3), (float(ALPHA_GRID[24]), 2e-3),
                        (between, 0.03), (0.3, 0.03), (0.1, 0.03)):
        expected = (rho * specular_at(specular, torch.full((count,), math.log(alpha))))
        for rotation in (0.0, 130.0):
            rendered = render(albedo, flat, rho, torch.full((count,), alpha), bank,
                              torch.arange(count), torch.full((count,), rotation))
            glossy = rendered - albedo * diffuse[:, :, None, None]
            assert torch.allclose(glossy, expected[:, :, None, None].expand_as(glossy),
                                  rtol=rtol, atol=1e-4), (alpha, rotation)


@pytest.mark.parametrize("config, mix_specular", [(TINY_AFFINE, True), (TINY_MAP, False)],
                         ids=["photo-affine", "map"])
def test_fitting_lowers_the_relit_error_and_reuses_its_prepared_data(tmp_path, bank, config,
                                                                      mix_specular):
    torch.manual_seed(0)
    net = SVBRDFNet(dataclasses.replace(config, joint_reading=True)).eval()
    cfg = FitConfig(work=str(tmp_path / "work"), maps=str(BUNDLED_MATERIALS), photos=40,
                    relights=2, mix_specular=mix_specular, steps=300)
    report = fit(cfg, net, bank)
    assert report["check_photos"] == 4
    assert (tmp_path / "work" / "fit.png").stat().st_size > 1000
    prepared = torch.load(tmp_path / "work" / "prepared.pt", weights_only=True)["data"]
    # a photo-affine network's albedo is made from the photo, a map network's kept
    assert ("photo" in prepared) == (config.albedo_network == "photo-affine")
    assert ("albedo" in prepared) == (config.albedo_network == "map")
    tables = flat_radiance_tables(bank)
    rows = torch.nonzero(prepared["photo_of_relight"] < 36)[:, 0]  # the fitted photos
    with torch.no_grad():
        before = relit_errors(None, prepared, tables, rows).mean()
        after = relit_errors(net.joint, prepared, tables, rows).mean()
    assert after < 0.8 * before
    # the same options again: the prepared data is read back, not made anew
    stamp = (tmp_path / "work" / "prepared.pt").stat().st_mtime_ns
    again = fit(dataclasses.replace(cfg, steps=10), net, bank)
    assert (tmp_path / "work" / "prepared.pt").stat().st_mtime_ns == stamp
    assert again["check_relit_before"] == pytest.approx(report["check_relit_before"])


@pytest.mark.parametrize("config", [TINY_AFFINE, TINY_MAP], ids=["photo-affine", "map"])
def test_a_model_file_keeps_the_head(tmp_path, config):
    torch.manual_seed(0)
    net = SVBRDFNet(dataclasses.replace(config, joint_reading=True)).eval()
    with torch.no_grad():
        net.joint.mlp[2].bias.copy_(torch.tensor([0.25, 0.0, -0.25, 0.5, 1.0][:net.joint.values]))
        net.joint.scale.fill_(2.0)
    path = tmp_path / "m.safetensors"
    save_model(net, path, {"class": "plastic"})
    loaded = load_network(path)
    assert loaded.config.joint_reading
    assert isinstance(loaded.joint, JointReading)
    assert model_metadata(path, FORMAT, "model")["class"] == "plastic"
    image = torch.rand(1, 3, 32, 32)
    with torch.no_grad():
        a, b = net(image), loaded(image)
    for name in a:  # float16 weights in the file
        assert torch.allclose(a[name], b[name], rtol=1e-2, atol=1e-2), name
