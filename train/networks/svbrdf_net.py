"""SVBRDF-net (the paper's section "SVBRDF-Net"): one analysis-synthesis network per output type.

All three networks share the structure of their analysis sub-network: ``levels`` blocks of
3x3 convolution, batch norm and ReLU, each followed by 2x2 max pooling; the first block has
``width`` channels and each next one twice as many, up to ``max_width``. Then:

- ``HomogeneousNet``: a fully connected synthesis with ``hidden`` (1024) hidden units that
  predicts the log relative specular albedo (3 values) and the log Ward roughness (1 value)
  (or, as BRDF-net, 2 values from a monochrome image). It reads the whole bottleneck (the
  paper's, ``homogeneous_pooling="flatten"``: a weight per position) or its average over
  positions (``"mean"``: the same features wherever they lie, as a homogeneous material's
  cues may lie anywhere in the photo).
  (The paper predicts a roughness per color channel; the reduced model and the labels here
  have one.)
- ``MapNet``: a U-Net style synthesis that mirrors the analysis, each block a 3x3 convolution,
  batch norm and ReLU, then bilinear upsampling and concatenation of the analysis features of
  the same size (skip links); a last 3x3 convolution, without batch norm, gives a (B, 3, H, W)
  map. One MapNet predicts the relative diffuse albedo, through a softplus: relative albedos
  exceed 1 where a color is saturated (a blue fabric's blue channel reaches 2.8), which the
  paper's sigmoid cannot reach. Another predicts the normals encoded (n + 1) / 2, through a
  sigmoid.
- ``PhotoAffineAlbedoNet`` (``albedo_network="photo-affine"``), the other albedo network: the
  relative albedo is the photo itself less a grey offset, the reflection, whose share of the
  photo's mean a homogeneous network (averaged bottleneck) predicts. Under the paper's
  conditions (a flat sample, distant lighting, a fronto-parallel view) the diffuse radiance
  is the albedo times one irradiance per channel and the specular reflection nearly one
  offset per channel, so the photo is, per channel, an affine function of the albedo: the
  offset is what the photo alone does not tell. The albedo keeps the photo's every detail,
  and with it what this model leaves out (the light's color, shading of relief, glints of a
  glossy relief).

Input: (B, 3, S, S) photos, linear RGB in [0, 1] (docs/conventions.md), S divisible by
2^levels. Outputs follow the label conventions of docs/dataset-format.md.
"""

import dataclasses
from collections.abc import Callable, Collection
from dataclasses import dataclass

import torch
from torch import nn
from torch.nn import functional

HOMOGENEOUS_POOLINGS = ("flatten", "mean")
"""How the homogeneous network reads its bottleneck (NetworkConfig.homogeneous_pooling)."""
ALBEDO_NETWORKS = ("map", "photo-affine")
"""What predicts the albedo (NetworkConfig.albedo_network): a MapNet, or a
PhotoAffineAlbedoNet."""


@dataclass(frozen=True)
class NetworkConfig:
    input_size: int = 256
    """Side of the square input photo (px); divisible by 2^levels."""
    width: int = 32
    """Channels of the first analysis block; each next block doubles them."""
    max_width: int = 256
    """Most channels of a block."""
    levels: int = 5
    """Analysis blocks (and poolings): 256 px in, an 8 x 8 bottleneck out."""
    hidden: int = 1024
    """Hidden units of the homogeneous network's fully connected synthesis."""
    homogeneous_pooling: str = "flatten"
    """What the homogeneous network's synthesis reads of the bottleneck: "flatten" (the
    paper's: every position, each with its own weights) or "mean" (the average over
    positions)."""
    albedo_network: str = "map"
    """The albedo network: "map" (the paper's: a U-Net predicts every pixel) or
    "photo-affine" (the photo less a predicted grey offset, PhotoAffineAlbedoNet)."""

    def __post_init__(self):
        if self.albedo_network not in ALBEDO_NETWORKS:
            raise ValueError(f"albedo_network {self.albedo_network!r} is not one of "
                             f"{', '.join(ALBEDO_NETWORKS)}")
        if self.homogeneous_pooling not in HOMOGENEOUS_POOLINGS:
            raise ValueError(f"homogeneous_pooling {self.homogeneous_pooling!r} is not one of "
                             f"{', '.join(HOMOGENEOUS_POOLINGS)}")
        if self.input_size % 2 ** self.levels:
            raise ValueError(f"input_size {self.input_size} is not divisible by 2^levels "
                             f"({2 ** self.levels})")

    def channels(self) -> list[int]:
        """Channels of each analysis block, from the input side."""
        return [min(self.width * 2 ** level, self.max_width) for level in range(self.levels)]


SMALL_CPU_CONFIG = NetworkConfig(input_size=64, width=8, max_width=64, levels=4, hidden=256)
"""A configuration that trains in minutes on a CPU (demo, tests)."""

COMPACT_CONFIG = NetworkConfig(input_size=256, width=16, max_width=128, levels=5, hidden=512)
"""The shipped models' configuration: the paper's input size and depth at half its widths and
hidden units, 6.2 M parameters (11.8 MiB in float16; the paper's is 24.8 M)."""


def _block(in_channels, out_channels):
    """3x3 convolution, batch norm, ReLU; the convolution's bias is redundant with the norm's."""
    return nn.Sequential(nn.Conv2d(in_channels, out_channels, 3, padding=1, bias=False),
                         nn.BatchNorm2d(out_channels), nn.ReLU(inplace=True))


class Analysis(nn.Module):
    """The shared structure: blocks each followed by 2x2 max pooling."""

    def __init__(self, config: NetworkConfig, in_channels: int = 3):
        super().__init__()
        channels = [in_channels] + config.channels()
        self.blocks = nn.ModuleList(_block(a, b) for a, b in zip(channels, channels[1:]))

    def forward(self, image: torch.Tensor) -> tuple[list[torch.Tensor], torch.Tensor]:
        """Features before each pooling (for skip links), and the pooled bottleneck."""
        features = []
        x = image  # (B, 3, S, S)
        for block in self.blocks:
            x = block(x)
            features.append(x)  # (B, C_l, S / 2^l, S / 2^l)
            x = functional.max_pool2d(x, 2)
        return features, x  # bottleneck (B, C_last, S / 2^levels, S / 2^levels)


class HomogeneousNet(nn.Module):
    """Image (B, in_channels, S, S) -> homogeneous parameters (B, outputs).

    In SVBRDF-net: a photo -> log relative specular albedo (3) and log roughness (1). In
    BRDF-net (the paper's validation): a monochrome sphere -> 2 values
    (train.brdf_validation.validation).
    """

    def __init__(self, config: NetworkConfig, in_channels: int = 3, outputs: int = 4):
        super().__init__()
        self.config, self.in_channels = config, in_channels
        self.analysis = Analysis(config, in_channels)
        features = config.channels()[-1]
        if config.homogeneous_pooling == "flatten":
            features *= (config.input_size // 2 ** config.levels) ** 2
        # Flatten: (B, C, s, s) -> (B, C s^2); it leaves the averaged (B, C) as it is, and
        # stays so that the weights keep their names (synthesis.1, synthesis.3) in every file
        self.synthesis = nn.Sequential(nn.Flatten(), nn.Linear(features, config.hidden),
                                       nn.ReLU(inplace=True), nn.Linear(config.hidden, outputs))

    def forward(self, image: torch.Tensor) -> torch.Tensor:
        check_images(image, self.in_channels, self.config.input_size)
        _, bottleneck = self.analysis(image)  # (B, C, s, s)
        if self.config.homogeneous_pooling == "mean":
            bottleneck = bottleneck.mean((2, 3))  # (B, C)
        return self.synthesis(bottleneck)


class MapNet(nn.Module):
    """Photo -> a (B, 3, S, S) map through a U-Net style synthesis, ending in ``activation``:
    ``torch.sigmoid`` for a map in [0, 1] (encoded normals) or ``functional.softplus`` for an
    unbounded positive one (relative albedo, which exceeds 1 for saturated colors)."""

    def __init__(self, config: NetworkConfig,
                 activation: Callable[[torch.Tensor], torch.Tensor]):
        super().__init__()
        self.activation = activation
        self.analysis = Analysis(config)
        channels = config.channels()
        inputs = [channels[-1]] + [2 * c for c in reversed(channels[1:])]
        self.synthesis = nn.ModuleList(_block(a, b) for a, b in zip(inputs, reversed(channels)))
        self.output = nn.Conv2d(2 * channels[0], 3, 3, padding=1)

    def forward(self, image: torch.Tensor) -> torch.Tensor:
        features, x = self.analysis(image)
        for block, skip in zip(self.synthesis, reversed(features)):
            x = functional.interpolate(block(x), scale_factor=2, mode="bilinear",
                                       align_corners=False)
            x = torch.cat([x, skip], 1)  # (B, 2 C_l, S / 2^l, S / 2^l)
        return self.activation(self.output(x))


class PhotoAffineAlbedoNet(nn.Module):
    """Photo (B, 3, S, S) -> relative albedo (B, 3, S, S), the photo less the reflection
    (photo_affine_albedo) whose share ``affine``, a homogeneous network with its bottleneck
    averaged, predicts."""

    def __init__(self, config: NetworkConfig):
        super().__init__()
        self.affine = HomogeneousNet(dataclasses.replace(config, homogeneous_pooling="mean"),
                                     outputs=1)

    def forward(self, image: torch.Tensor, reference: torch.Tensor | None = None) -> torch.Tensor:
        """The albedo of ``image``; with ``reference`` (B, 3, S, S), the reflection's share
        is predicted from it instead, and ``image`` may have any size (a full-resolution
        photo mapped as its network-size view is: train.estimation.full_resolution)."""
        return photo_affine_albedo(self.affine(image if reference is None else reference),
                                   image)


AFFINE_OFFSET_SHARPNESS = 100.0
"""Sharpness (beta, 1 / photo value) of the softplus that keeps the photo minus its offset
positive: it differs from max(x, 0) by at most log(2) / 100 = 0.007."""


def photo_affine_albedo(logit: torch.Tensor, image: torch.Tensor) -> torch.Tensor:
    """The relative albedo (B, 3, H, W) of ``image`` (B, 3, H, W), a linear RGB photo, less
    the reflection: a grey offset, ``sigmoid(logit)`` ((B, 1), the reflection's share) times
    the photo's mean over pixels and channels; kept positive by a softplus and scaled to
    mean 0.5 over pixels and channels, the labels' convention (docs/conventions.md)."""
    offset = torch.sigmoid(logit)[:, :, None, None] * image.mean((1, 2, 3), keepdim=True)
    albedo = functional.softplus(image - offset, beta=AFFINE_OFFSET_SHARPNESS)
    return albedo * (0.5 / albedo.mean((1, 2, 3), keepdim=True))


PARTS = {"homogeneous": ("log_specular", "log_roughness"), "albedo": ("albedo",),
         "normal": ("normal",)}
"""The three networks of SVBRDFNet (its attribute names) and the labels each predicts."""


class SVBRDFNet(nn.Module):
    """The union of the three networks; ``forward`` returns the label quantities.

    Its convolution weights are kept in the channels-last memory layout (``module.to`` and
    ``load_state_dict`` keep it), in which oneDNN convolves about twice as fast on a CPU
    (docs/performance.md); the values equal the default layout's up to float rounding."""

    def __init__(self, config: NetworkConfig = NetworkConfig()):
        super().__init__()
        self.config = config
        self.homogeneous = HomogeneousNet(config)
        self.albedo = (MapNet(config, functional.softplus) if config.albedo_network == "map"
                       else PhotoAffineAlbedoNet(config))
        self.normal = MapNet(config, torch.sigmoid)
        self.to(memory_format=torch.channels_last)

    def forward(self, image: torch.Tensor,
                parts: Collection[str] = tuple(PARTS)) -> dict[str, torch.Tensor]:
        """``image`` (B, 3, S, S) -> dict of albedo (B, 3, S, S) relative diffuse albedo
        (positive, mean about 0.5); normal (B, 3, S, S) unit tangent-space normals;
        log_specular (B, 3); log_roughness (B, 1). Only the networks named in ``parts`` (keys
        of PARTS) run, and only their labels are returned (training one network alone)."""
        check_images(image, 3, self.config.input_size)
        outputs = {}
        if "homogeneous" in parts:
            homogeneous = self.homogeneous(image)  # (B, 4)
            outputs["log_specular"], outputs["log_roughness"] = (homogeneous[:, :3],
                                                                 homogeneous[:, 3:])
        if "albedo" in parts:
            outputs["albedo"] = self.albedo(image)
        if "normal" in parts:
            outputs["normal"] = decode_normal(self.normal(image))
        return outputs


def check_images(image: torch.Tensor, channels: int, size: int) -> None:
    """Raise ValueError unless ``image`` is (B, channels, size, size) of finite values."""
    if image.ndim != 4 or image.shape[1:] != (channels, size, size):
        raise ValueError(f"expected images of shape (B, {channels}, {size}, {size}), got "
                         f"{tuple(image.shape)}")
    if not torch.isfinite(image).all():
        raise ValueError("images hold NaN or infinite values")


def decode_normal(encoded: torch.Tensor) -> torch.Tensor:
    """(B, 3, H, W) normals encoded (n + 1) / 2 in [0, 1] -> unit vectors with z >= 0.05."""
    normal = encoded * 2.0 - 1.0
    normal = torch.cat([normal[:, :2], normal[:, 2:].clamp(min=0.05)], 1)
    return functional.normalize(normal, dim=1)
