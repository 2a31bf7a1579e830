"""Self-augmentation (the paper's "Training by Self-Augmentation"): a labeled pair made from an
unlabeled photo by the network itself and the exact renderer.

The network, in evaluation mode, predicts provisional parameters for the photos; they are
clamped to the valid range and rendered by the torch renderer under a random probe, rotation
and view, auto-exposed and clamped like the dataset's images. The render and the provisional
parameters, renormalized to a mean relative albedo of 0.5 (the exposure makes the render
independent of that scale), form a labeled minibatch. Unlike the photo, the render is exactly
consistent with those parameters, so training on it pulls the network toward the renderer's
inverse.
"""

import numpy as np
import torch

from render.common.exposure import expose
from render.common.views import random_view
from render.torch_renderer.renderer import render
from train.losses import clamp_to_valid


def random_lightings(rng, count, probe_choices, max_view_angle=0.0):
    """``count`` random lightings and views drawn from ``rng`` (numpy Generator): probe indices
    (count,) among ``probe_choices`` (indices into the probe bank), rotations in degrees about
    +z (count,) and unit view directions (count, 3)."""
    probe_choices = np.asarray(probe_choices)
    probe_index = probe_choices[rng.integers(len(probe_choices), size=count)]
    rotation_deg = rng.uniform(0.0, 360.0, size=count)
    view = np.stack([random_view(rng, max_view_angle) for _ in range(count)])
    return probe_index, rotation_deg, view


def self_augmented_batch(net, photos, probes, lightings, log_specular_range):
    """A labeled minibatch (image, albedo, normal, log_specular, log_roughness) from ``photos``
    (B, 3, S, S), rendered under ``lightings`` (random_lightings of B)."""
    training = net.training
    net.eval()
    with torch.no_grad():
        provisional = clamp_to_valid(net(photos), log_specular_range)
    net.train(training)

    dtype = photos.dtype
    probe_index = torch.as_tensor(lightings[0])
    rotation = torch.as_tensor(lightings[1], dtype=dtype)
    view = torch.as_tensor(lightings[2], dtype=dtype)
    albedo = provisional["albedo"]
    hdr = render(albedo, provisional["normal"], torch.exp(provisional["log_specular"]),
                 torch.exp(provisional["log_roughness"]), probes, probe_index, rotation, view)
    scale = 2.0 * albedo.mean((1, 2, 3))  # (B,) relative albedo back to mean 0.5
    return {"image": expose(hdr).to(dtype), "albedo": albedo / scale[:, None, None, None],
            "normal": provisional["normal"],
            "log_specular": provisional["log_specular"] - torch.log(scale)[:, None],
            "log_roughness": provisional["log_roughness"]}
