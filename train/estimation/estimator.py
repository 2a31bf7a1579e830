"""Estimation of one photo, and the Python API for it.

    from train.estimation import Estimator

    estimator = Estimator()                    # the default shipped network
    result = estimator.estimate_file("photo.jpg")
    result.albedo, result.normal               # (H, W, 3) float32 maps over the whole photo
    result.specular_albedo, result.roughness   # the homogeneous Ward lobe

An Estimator loads its network once (train.estimation.network_choice: a given model file or a
shipped class network; by default, for a material of unknown kind, the plastic network with
the fixed lobe) and estimates any number of photos.
``sa-estimate`` (train.estimation.batch) is built on it, so a script gets exactly what the
command writes.

The estimate of a photo, as sa-evaluate measures it:
1. its centre square at the network's input size S (train.data.photos.network_view) gives the
   specular albedo and roughness (``choice_estimate``: the network's S x S estimate, its lobe
   the fixed one where the choice says so);
2. the albedo and normal maps cover the whole photo at its own resolution, the longer side at
   most ``max_side`` (train.estimation.full_resolution).

Conventions (docs/conventions.md): photos are linear RGB; albedos are *relative* (scaled so
that the diffuse albedo averages about 0.5 over the channels, the photo's exposure being
unknown) and so is the specular albedo; normals are unit tangent-space vectors, x right, y up
the image (OpenGL convention), z out of the surface; roughness is the Ward alpha (the RMS
slope of the microfacets), in [0.02, 1].
"""

import dataclasses
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from render.materials.reduced_svbrdf import ReducedSVBRDF
from train.data.photos import network_view, photo_problem, read_linear_photo
from train.estimation.full_resolution import MAX_SIDE, full_resolution_maps
from train.estimation.network_choice import (
    DEFAULT_CLASS,
    FIXED_ROUGHNESS,
    FIXED_SPECULAR,
    FixedNetwork,
    network_choice,
)
from train.networks.svbrdf_net import SVBRDFNet


def estimate(net: SVBRDFNet, photo: np.ndarray) -> ReducedSVBRDF:
    """(3, S, S) photo -> ReducedSVBRDF of relative quantities (name unset)."""
    with torch.no_grad():
        output = net(torch.as_tensor(photo)[None].to(next(net.parameters()).device))
    albedo = output["albedo"][0].cpu().numpy().transpose(1, 2, 0)
    normal = output["normal"][0].cpu().numpy().transpose(1, 2, 0)
    specular = np.exp(output["log_specular"][0].cpu().numpy())
    roughness = float(np.clip(np.exp(output["log_roughness"][0, 0].item()), 0.02, 1.0))
    return ReducedSVBRDF("", np.ascontiguousarray(albedo), np.ascontiguousarray(normal),
                         specular.astype(np.float32), roughness)


def choice_estimate(choice: FixedNetwork,
                    photo: np.ndarray) -> tuple[ReducedSVBRDF, SVBRDFNet, dict]:
    """(3, S, S) photo -> the estimate of ``choice`` (``estimate`` of its network, with the
    fixed lobe where ``choice.fixed_lobe``), the network, and the dict that says which network
    and whose lobe (train.estimation.network_choice)."""
    net, chosen = choice.for_photo(photo)
    svbrdf = estimate(net, photo)
    if choice.fixed_lobe:
        svbrdf = dataclasses.replace(svbrdf, specular=np.full(3, FIXED_SPECULAR, np.float32),
                                     roughness=FIXED_ROUGHNESS)
    return svbrdf, net, chosen


@dataclass(frozen=True)
class Estimate:
    """The reduced SVBRDF estimated from one photo (conventions: the module docstring)."""

    albedo: np.ndarray
    """(H, W, 3) float32 relative diffuse albedo, linear RGB, over the whole photo."""
    normal: np.ndarray
    """(H, W, 3) float32 unit tangent-space normals (OpenGL convention, z > 0)."""
    specular_albedo: np.ndarray
    """(3,) float32 relative Ward specular albedo, linear RGB."""
    roughness: float
    """Ward alpha (unitless), in [0.02, 1]."""
    network: dict
    """Which network estimated the photo: ``model`` (its file), and whose lobe the estimate
    has: ``lobe``, ``read`` (the network's reading) or ``fixed``."""
    network_ms: float
    """Milliseconds of the network-size estimate."""
    full_resolution_ms: float
    """Milliseconds of the full-resolution maps."""

    def svbrdf(self, name: str = "") -> ReducedSVBRDF:
        """The estimate as a ReducedSVBRDF named ``name`` (render.materials: writable as a
        material folder, a glTF file or a Mitsuba scene)."""
        return ReducedSVBRDF(name, self.albedo, self.normal, self.specular_albedo,
                             self.roughness)


class Estimator:
    """Networks loaded once, to estimate photos (the module docstring)."""

    def __init__(self, model: str | Path | None = None, material_class: str = DEFAULT_CLASS,
                 device: str = "cpu", max_side: int = MAX_SIDE):
        """``model``: a model file (.safetensors), an sa-train checkpoint (.pt) or a run folder;
        without one, the shipped network of ``material_class`` (wood, plastic, metal).
        ``device``: the torch device of the networks. ``max_side``: the longest side (px) of
        the maps; a smaller photo keeps its own size."""
        if max_side < 16:
            raise ValueError(f"max_side {max_side} is below 16 px")
        self.choice = network_choice(model, material_class, device)
        self.material_class = None if model is not None else material_class
        """The shipped class asked for, or None where a model file was given."""
        self.max_side = max_side

    @property
    def input_size(self) -> int:
        """The side S (px) of the square view the networks read."""
        return self.choice.input_size

    def estimate(self, linear_photo: np.ndarray) -> Estimate:
        """The estimate of a photo given as an (H, W, 3) array of linear RGB, about [0, 1]
        (what train.data.photos.read_linear_photo reads from a file: an 8-bit photo decoded
        with gamma 2.2, an HDR one auto-exposed)."""
        check_linear_photo(linear_photo)
        linear_photo = linear_photo.astype(np.float32, copy=False)
        photo = network_view(linear_photo, self.input_size)
        start = time.perf_counter()
        small, net, chosen = choice_estimate(self.choice, photo)
        network_ms = 1000.0 * (time.perf_counter() - start)
        start = time.perf_counter()
        albedo, normal = full_resolution_maps(net, linear_photo, self.max_side)
        full_resolution_ms = 1000.0 * (time.perf_counter() - start)
        return Estimate(albedo, normal, small.specular, small.roughness, chosen, network_ms,
                        full_resolution_ms)

    def estimate_file(self, path: str | Path) -> Estimate:
        """The estimate of a photo file (PNG, JPEG, TIFF, BMP, EXR, HDR; read by
        train.data.photos.read_linear_photo)."""
        return self.estimate(read_linear_photo(path))


def check_linear_photo(pixels: np.ndarray) -> None:
    """A ValueError naming what it got unless ``pixels`` is an (H, W, 3) float array that
    train.data.photos.photo_problem finds nothing wrong with."""
    if not isinstance(pixels, np.ndarray) or pixels.ndim != 3 or pixels.shape[2] != 3:
        raise ValueError("expected an (H, W, 3) numpy array of linear RGB, got "
                         f"{getattr(pixels, 'shape', type(pixels).__name__)}")
    if not np.issubdtype(pixels.dtype, np.floating):
        raise ValueError(f"expected floating-point linear RGB, got {pixels.dtype}")
    problem = photo_problem(pixels)
    if problem:
        raise ValueError(problem)
