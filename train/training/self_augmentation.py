"""Self-augmentation (the paper's "Training by Self-Augmentation"): a labeled pair made from an
unlabeled photo by the network itself and the exact renderer.

The network predicts provisional parameters for the photos (batch norm on the minibatch's own
statistics, running statistics untouched); they are renormalized to a mean relative albedo of
0.5 (the exposure makes the render independent of that scale), clamped to the valid range of
the labels, and rendered by the torch renderer under a random probe, rotation and view,
auto-exposed and clamped like the dataset's images. The render and those parameters form a
labeled minibatch. Unlike the photo, the render is exactly
consistent with those parameters, so training on it pulls the network toward the renderer's
inverse.
"""

from collections.abc import Sequence
from typing import Any

import numpy as np
import torch

from render.common.exposure import expose
from render.common.views import random_view
from render.torch_renderer.renderer import ProbeBank, render
from train.networks.svbrdf_net import SVBRDFNet
from train.training.losses import clamp_to_valid


def random_lightings(rng: np.random.Generator, count: int,
                     probe_choices: Sequence[int] | np.ndarray, max_view_angle: float = 0.0
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``count`` random lightings and views drawn from ``rng`` (numpy Generator): probe indices
    (count,) among ``probe_choices`` (indices into the probe bank), rotations in degrees about
    +z (count,) and unit view directions (count, 3)."""
    probe_choices = np.asarray(probe_choices)
    probe_index = probe_choices[rng.integers(len(probe_choices), size=count)]
    rotation_deg = rng.uniform(0.0, 360.0, size=count)
    view = np.stack([random_view(rng, max_view_angle) for _ in range(count)])
    return probe_index, rotation_deg, view


def provisional_parameters(net: torch.nn.Module, photos: torch.Tensor,
                           batch_statistics: bool = True) -> Any:
    """The network's predictions for ``photos`` (what ``net(photos)`` returns: SVBRDF-net's
    parameter dict, BRDF-net's (B, 2) targets), without gradients; the running statistics are
    left as they were (the provisional pass is not a training step). Both self-augmentations
    take their provisional labels here: SVBRDF-net's (``self_augmented_batch``) and BRDF-net's
    in the paper's validation (train.brdf_validation.validation).

    ``batch_statistics``: batch norm normalizes by the minibatch's own statistics, as in
    training (SVBRDF-net: predicting with the running statistics instead, which the
    self-augmented renders themselves keep moving, biased the predictions and let the specular
    albedo drift, docs/training.md); or, False, by the running statistics, as in evaluation
    (BRDF-net: its labeled set can be 8 corners of the search space and its unlabeled spheres
    the interior, a minibatch of which its own statistics would normalize toward the corners';
    with the minibatch's statistics its 2x2x2 error with self-augmentation was 1.2x to 1.7x
    higher in each of 3 seeds, docs/brdf-validation.md)."""
    running = [buffer.clone() for buffer in net.buffers()]
    training = net.training
    net.train(batch_statistics)
    with torch.no_grad():
        prediction = net(photos)
        for buffer, saved in zip(net.buffers(), running):
            buffer.copy_(saved)
    net.train(training)
    return prediction


def self_augmented_batch(net: SVBRDFNet, photos: torch.Tensor, probes: ProbeBank,
                         lightings: Sequence[np.ndarray],
                         log_specular_range: tuple[float, float]) -> dict[str, torch.Tensor]:
    """A labeled minibatch (image, albedo, normal, log_specular, log_roughness) from ``photos``
    (B, 3, S, S), rendered under ``lightings`` (random_lightings of B)."""
    provisional = provisional_parameters(net, photos)
    scale = 2.0 * provisional["albedo"].mean((1, 2, 3))  # (B,) relative albedo back to mean 0.5
    labels = clamp_to_valid({
        "albedo": provisional["albedo"] / scale[:, None, None, None],
        "normal": provisional["normal"],
        "log_specular": provisional["log_specular"] - torch.log(scale)[:, None],
        "log_roughness": provisional["log_roughness"]}, log_specular_range)

    dtype = photos.dtype
    probe_index = torch.as_tensor(lightings[0])
    rotation = torch.as_tensor(lightings[1], dtype=dtype)
    view = torch.as_tensor(lightings[2], dtype=dtype)
    hdr = render(labels["albedo"], labels["normal"], torch.exp(labels["log_specular"]),
                 torch.exp(labels["log_roughness"][:, 0]), probes, probe_index, rotation, view)
    return {"image": expose(hdr).to(dtype), **labels}
