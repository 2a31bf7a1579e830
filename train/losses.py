"""Training losses and evaluation errors of SVBRDF-net, on the label quantities of
docs/dataset-format.md (relative albedo, unit normals, log relative specular albedo, log
roughness).

Each of the three networks is trained on the mean squared error of its own outputs (the paper
trains a separate network per output type; their parameters are disjoint, so one summed loss
gives each network exactly its own gradient).
"""

import math

import torch

from render.common.exposure import expose
from render.torch_renderer.renderer import render

LABELS = ("albedo", "normal", "log_specular", "log_roughness")


def losses(prediction, target):
    """Mean squared error per label that ``prediction`` holds, and their sum under "total"."""
    terms = {name: torch.mean((prediction[name] - target[name]) ** 2) for name in LABELS
             if name in prediction}
    terms["total"] = sum(terms.values())
    return terms


def normal_angle_deg(prediction, target):
    """Mean angle (degrees) between predicted and true unit normals (B, 3, H, W)."""
    cosine = (prediction * target).sum(1).clamp(-1.0, 1.0)
    return torch.rad2deg(torch.acos(cosine)).mean()


def relit(parameters, probes, probe_index, rotation_deg):
    """Exposed torch renders (B, 3, H, W) of label-form parameters under the given probes and
    rotations."""
    hdr = render(parameters["albedo"], parameters["normal"], torch.exp(parameters["log_specular"]),
                 torch.exp(parameters["log_roughness"]).clamp(0.02, 1.0), probes, probe_index,
                 rotation_deg)
    return expose(hdr)


MAX_RELATIVE_ALBEDO = 4.0
"""Largest relative albedo a provisional estimate keeps (labels reach about 3 for saturated
colors)."""


def clamp_to_valid(prediction, log_specular_range):
    """Parameters clamped to the range the renderer and the labels allow: relative albedo in
    [0.01, MAX_RELATIVE_ALBEDO], Ward roughness in [0.02, 1], log relative specular albedo in
    the given range."""
    low, high = log_specular_range
    return {"albedo": prediction["albedo"].clamp(0.01, MAX_RELATIVE_ALBEDO),
            "normal": prediction["normal"],
            "log_specular": prediction["log_specular"].clamp(low, high),
            "log_roughness": prediction["log_roughness"].clamp(math.log(0.02), 0.0)}
