"""Training losses and evaluation errors of SVBRDF-net, on the label quantities of
docs/dataset-format.md (relative albedo, unit normals, log relative specular albedo, log
roughness).

Each of the three networks is trained on the mean squared error of its own outputs (the paper
trains a separate network per output type; their parameters are disjoint, so one summed loss
gives each network exactly its own gradient).
"""

import math
from collections.abc import Sequence

import numpy as np
import torch
from torch.nn import functional

from render.common.exposure import expose
from render.torch_renderer.renderer import ProbeBank, render

LABELS = ("albedo", "normal", "log_specular", "log_roughness")
ALBEDO_LOSSES = ("linear", "log")
LOG_ALBEDO_OFFSET = 0.01
"""The albedo loss "log" compares log(albedo + LOG_ALBEDO_OFFSET): relative albedos, mean 0.5,
of dark materials lie near 0.02."""


def losses(prediction: dict[str, torch.Tensor], target: dict[str, torch.Tensor],
           albedo_loss: str = "linear") -> dict[str, torch.Tensor]:
    """Mean squared error per label that ``prediction`` holds, and their sum under "total".

    ``albedo_loss``: "linear", the paper's, on the relative albedo itself; or "log", on
    log(albedo + LOG_ALBEDO_OFFSET), where an error counts relative to the albedo: a dark
    region estimated at 0.08 instead of 0.02 weighs more than a bright speck at 12 instead of
    15 (relative albedos of dark materials with bright specks reach 16, and dominate the
    linear loss)."""
    terms = {}
    for name in (name for name in LABELS if name in prediction):
        estimate, truth = prediction[name], target[name]
        if name == "albedo" and albedo_loss == "log":
            estimate, truth = (torch.log(x + LOG_ALBEDO_OFFSET) for x in (estimate, truth))
        terms[name] = torch.mean((estimate - truth) ** 2)
    terms["total"] = sum(terms.values())
    return terms


def normal_angle_deg(prediction: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """Mean angle (degrees) between predicted and true unit normals (B, 3, H, W)."""
    cosine = (prediction * target).sum(1).clamp(-1.0, 1.0)
    return torch.rad2deg(torch.acos(cosine)).mean()


def render_parameters(parameters: dict[str, torch.Tensor], probes: ProbeBank,
                      probe_index: torch.Tensor | np.ndarray | Sequence[int],
                      rotation_deg: torch.Tensor | np.ndarray | Sequence[float]) -> torch.Tensor:
    """HDR torch renders (B, 3, H, W) of label-form parameters (roughness clamped to [0.02, 1])
    under the given probes and rotations."""
    return render(parameters["albedo"], parameters["normal"],
                  torch.exp(parameters["log_specular"]),
                  torch.exp(parameters["log_roughness"][:, 0]).clamp(0.02, 1.0), probes,
                  probe_index, rotation_deg)


def relit(parameters: dict[str, torch.Tensor], probes: ProbeBank,
          probe_index: torch.Tensor | np.ndarray | Sequence[int],
          rotation_deg: torch.Tensor | np.ndarray | Sequence[float]) -> torch.Tensor:
    """Exposed torch renders (B, 3, H, W) of label-form parameters under the given probes and
    rotations."""
    return expose(render_parameters(parameters, probes, probe_index, rotation_deg))


def maps_at_size(parameters: dict[str, torch.Tensor], size: int) -> dict[str, torch.Tensor]:
    """``parameters`` with its albedo and normal maps box filtered (normals renormalized) to
    ``size`` x ``size``."""
    if parameters["albedo"].shape[-1] == size:
        return parameters
    albedo = functional.interpolate(parameters["albedo"], size=(size, size), mode="area")
    normal = functional.normalize(functional.interpolate(parameters["normal"], size=(size, size),
                                                         mode="area"), dim=1)
    return parameters | {"albedo": albedo, "normal": normal}


RELIT_LOSS_FORMS = ("log", "rmse")
"""How relit_loss compares the two renders."""
RELIT_CLAMP_LEAK = 0.01
"""Slope of the estimate's render beyond [0, 1] in the "rmse" relit loss (where the evaluation
clamps it flat), so that a too bright estimate is still pulled down."""


def relit_loss(prediction: dict[str, torch.Tensor], target: dict[str, torch.Tensor],
               probes: ProbeBank, probe_index: torch.Tensor | np.ndarray | Sequence[int],
               rotation_deg: torch.Tensor | np.ndarray | Sequence[float], size: int,
               form: str = "log") -> torch.Tensor:
    """How differently the prediction and the truth look under other lighting, both rendered
    under the given probes and rotations (each sample its own) and exposed as the truth's
    render is exposed. Maps are box filtered to ``size`` px first; a label ``prediction``
    lacks (a network not trained) is taken from ``target``. ``form`` (RELIT_LOSS_FORMS):

    - "log": the mean squared difference of log(1 + x) of the renders, not clamped (a too
      bright estimate still gets a gradient; the log compresses highlights);
    - "rmse": the evaluation's relit error itself (train.evaluation.estimate_evaluation): per
      sample the root mean squared difference of the renders clamped to [0, 1], averaged over
      samples; the estimate's clamp leaks (RELIT_CLAMP_LEAK). Squared errors are averaged
      within a sample before the root, so a few badly relit samples weigh less than in "log"."""
    if form not in RELIT_LOSS_FORMS:
        raise ValueError(f"relit loss form {form!r}: one of {RELIT_LOSS_FORMS}")
    truth = maps_at_size({name: target[name] for name in LABELS}, size)
    estimate = maps_at_size({name: prediction.get(name, target[name]) for name in LABELS}, size)
    truth_hdr = render_parameters(truth, probes, probe_index, rotation_deg).detach()
    estimate_hdr = render_parameters(estimate, probes, probe_index, rotation_deg)
    exposed = [expose(hdr, reference=truth_hdr, clamp=False) for hdr in (truth_hdr, estimate_hdr)]
    if form == "log":
        return torch.mean((torch.log1p(exposed[1]) - torch.log1p(exposed[0])) ** 2)
    return clamped_relit_rmse(exposed[1], exposed[0].clamp(0.0, 1.0), RELIT_CLAMP_LEAK).mean()


def clamped_relit_rmse(estimate: torch.Tensor, truth: torch.Tensor,
                       leak: float = 0.0) -> torch.Tensor:
    """(B,) per image, the RMSE between the exposed ``estimate`` (B, 3, H, W), clamped to
    [0, 1] as the evaluation clamps it, and the clamped exposed ``truth``; the clamp leaks with
    slope ``leak`` beyond [0, 1] (RELIT_CLAMP_LEAK when it is a loss)."""
    clamped = estimate.clamp(0.0, 1.0)
    leaky = clamped + leak * (estimate - clamped)
    return torch.sqrt(((leaky - truth) ** 2).mean((1, 2, 3)) + 1e-12)


MAX_RELATIVE_ALBEDO = 4.0
"""Largest relative albedo a provisional estimate keeps (labels reach about 3 for saturated
colors)."""


def clamp_to_valid(prediction: dict[str, torch.Tensor],
                   log_specular_range: tuple[float, float]) -> dict[str, torch.Tensor]:
    """Parameters clamped to the range the renderer and the labels allow: relative albedo in
    [0.01, MAX_RELATIVE_ALBEDO], Ward roughness in [0.02, 1], log relative specular albedo in
    the given range."""
    low, high = log_specular_range
    return {"albedo": prediction["albedo"].clamp(0.01, MAX_RELATIVE_ALBEDO),
            "normal": prediction["normal"],
            "log_specular": prediction["log_specular"].clamp(low, high),
            "log_roughness": prediction["log_roughness"].clamp(math.log(0.02), 0.0)}
