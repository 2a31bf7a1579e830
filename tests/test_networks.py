"""SVBRDF-net: shapes, ranges, skip links, configuration checks, and the paper's optimizer."""

import dataclasses

import pytest
import torch

from train.networks.svbrdf_net import (
    SMALL_CPU_CONFIG,
    HomogeneousNet,
    MapNet,
    NetworkConfig,
    PhotoAffineAlbedoNet,
    SVBRDFNet,
    decode_normal,
    photo_affine_albedo,
)
from train.training.optimization import OptimizerConfig, inverse_decay, make_optimizer

TINY = NetworkConfig(input_size=32, width=4, max_width=16, levels=3, hidden=32)


def test_outputs_have_the_label_shapes_and_ranges():
    torch.manual_seed(0)
    net = SVBRDFNet(TINY)
    output = net(torch.rand(2, 3, 32, 32))
    assert output["albedo"].shape == output["normal"].shape == (2, 3, 32, 32)
    assert output["log_specular"].shape == (2, 3) and output["log_roughness"].shape == (2, 1)
    assert output["albedo"].min() > 0
    assert torch.allclose(output["normal"].norm(dim=1), torch.ones(2, 32, 32), atol=1e-5)
    assert output["normal"][:, 2].min() > 0


def test_relative_albedo_labels_above_one_are_reachable():
    """Saturated colors have relative albedo labels above 1 (a blue fabric's blue channel
    reaches 2.8): the albedo network fits a constant 2.5 target, which a sigmoid could not."""
    torch.manual_seed(0)
    net = SVBRDFNet(TINY)
    optimizer = torch.optim.Adam(net.albedo.parameters(), lr=0.01)
    image = torch.rand(4, 3, 32, 32)
    for _ in range(150):
        loss = torch.mean((net(image)["albedo"] - 2.5) ** 2)
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
    albedo = net.eval()(image)["albedo"]
    assert abs(float(albedo.mean()) - 2.5) < 0.25


def test_every_parameter_gets_a_gradient():
    torch.manual_seed(0)
    net = SVBRDFNet(TINY)
    output = net(torch.rand(2, 3, 32, 32))
    loss = sum(value.square().mean() for value in output.values())
    loss.backward()
    for name, parameter in net.named_parameters():
        assert parameter.grad is not None and parameter.grad.abs().sum() > 0, name


def test_skip_links_carry_fine_detail_to_the_output():
    """A one-pixel change of the input changes the map output at that pixel more than far
    away: the full-resolution skip link reaches the output."""
    torch.manual_seed(0)
    net = MapNet(TINY, torch.sigmoid).eval()
    image = torch.rand(1, 3, 32, 32)
    changed = image.clone()
    changed[0, :, 16, 16] = 1 - changed[0, :, 16, 16]
    difference = (net(changed) - net(image)).abs().sum(1)[0]
    assert difference[16, 16] > 10 * difference[0, 0]


def test_mean_pooled_homogeneous_network_reads_the_bottleneck_wherever_a_feature_lies():
    """Averaged over positions, the bottleneck gives the same output when its positions are
    permuted; flattened (the paper's), it does not."""
    torch.manual_seed(0)
    image = torch.rand(2, 3, 32, 32)
    for pooling, invariant in (("mean", True), ("flatten", False)):
        net = HomogeneousNet(dataclasses.replace(TINY, homogeneous_pooling=pooling)).eval()
        _, bottleneck = net.analysis(image)  # (2, 16, 4, 4)
        flipped = bottleneck.flip(2, 3)
        pooled = [b.mean((2, 3)) if pooling == "mean" else b for b in (bottleneck, flipped)]
        outputs = [net.synthesis(b) for b in pooled]
        assert torch.allclose(net(image), outputs[0], atol=1e-6)
        assert torch.allclose(outputs[0], outputs[1], atol=1e-6) == invariant, pooling


def test_photo_affine_albedo_takes_away_a_grey_reflection():
    """A photo made of a known albedo plus a grey reflection comes back as that albedo from
    the reflection's share of the photo's mean; with no share, the reflection stays and
    lowers the contrast; with too large a share, the darkest pixels go to the softplus's
    floor."""
    torch.manual_seed(0)
    albedo = 0.5 + torch.rand(2, 3, 16, 16)
    albedo = albedo * (0.5 / albedo.mean((1, 2, 3), keepdim=True))  # the labels' mean 0.5
    reflection = torch.tensor([0.4, 0.1])[:, None, None, None]
    photo = 0.3 * (albedo + reflection)  # any exposure
    share = reflection / (albedo + reflection).mean((1, 2, 3), keepdim=True)
    logit = torch.logit(share[:, :, 0, 0])
    assert torch.allclose(photo_affine_albedo(logit, photo), albedo, atol=1e-4)
    no_offset = photo_affine_albedo(torch.full((2, 1), -30.0), photo)
    assert torch.allclose(no_offset, photo * 0.5 / photo.mean((1, 2, 3), keepdim=True),
                          atol=1e-4)
    assert (no_offset.std((1, 2, 3)) < albedo.std((1, 2, 3)) - 0.01).all()
    too_much = photo_affine_albedo(torch.full((2, 1), 30.0), photo)  # all of the mean taken
    assert too_much.min() < 0.01 and torch.allclose(too_much.mean((1, 2, 3)), torch.full((2,), 0.5))
    net = PhotoAffineAlbedoNet(TINY).eval()
    output = net(torch.rand(2, 3, 32, 32))
    assert output.shape == (2, 3, 32, 32) and output.min() > 0
    assert torch.allclose(output.mean((1, 2, 3)), torch.full((2,), 0.5))


def test_separate_networks_per_output_type():
    net = SVBRDFNet(TINY)
    albedo_weights = {id(p) for p in net.albedo.parameters()}
    assert not albedo_weights & {id(p) for p in net.normal.parameters()}
    assert not albedo_weights & {id(p) for p in net.homogeneous.parameters()}


def test_configuration_checks():
    with pytest.raises(ValueError, match="divisible"):
        NetworkConfig(input_size=100, levels=3)
    with pytest.raises(ValueError, match="homogeneous_pooling 'max' is not one of flatten, mean"):
        NetworkConfig(homogeneous_pooling="max")
    with pytest.raises(ValueError, match="albedo_network 'pixels' is not one of map, photo-affine"):
        NetworkConfig(albedo_network="pixels")
    size = TINY.input_size
    with pytest.raises(ValueError, match=rf"expected images of shape \(B, 3, {size}, {size}\), "
                                         rf"got \(1, 3, 64, 64\)"):
        SVBRDFNet(TINY)(torch.rand(1, 3, 64, 64))
    with pytest.raises(ValueError, match=r"got \(1, 32, 32, 3\)"):  # channel-last
        SVBRDFNet(TINY)(torch.rand(1, size, size, 3))
    with pytest.raises(ValueError, match="NaN or infinite"):
        SVBRDFNet(TINY)(torch.full((1, 3, size, size), float("nan")))
    with pytest.raises(ValueError, match=rf"expected images of shape \(B, 1, {size}, {size}\)"):
        HomogeneousNet(TINY, in_channels=1, outputs=2)(torch.rand(2, 3, size, size))
    assert NetworkConfig().channels() == [32, 64, 128, 256, 256]
    small = sum(p.numel() for p in SVBRDFNet(SMALL_CPU_CONFIG).parameters())
    assert small < 2_000_000  # trains on a CPU in minutes


def test_decode_normal():
    encoded = torch.tensor([0.5, 0.5, 1.0]).view(1, 3, 1, 1)
    assert torch.allclose(decode_normal(encoded).flatten(), torch.tensor([0.0, 0.0, 1.0]))
    grazing = decode_normal(torch.tensor([1.0, 0.5, 0.5]).view(1, 3, 1, 1)).flatten()
    assert grazing[2] > 0 and torch.isclose(grazing.norm(), torch.tensor(1.0))


def test_inverse_learning_rate_policy_and_adam_settings():
    config = OptimizerConfig()
    parameter = torch.nn.Parameter(torch.zeros(3))
    optimizer, scheduler = make_optimizer([parameter], config)
    group = optimizer.param_groups[0]
    assert group["betas"] == (0.9, 0.999) and group["weight_decay"] == 1e-4
    for _ in range(5000):
        optimizer.step()
        scheduler.step()
    expected = 0.002 * (1 + 1e-4 * 5000) ** -1.0  # Caffe's "inv": base (1 + gamma it)^-power
    assert abs(group["lr"] - expected) < 1e-12
    assert inverse_decay(0, config) == 1.0
