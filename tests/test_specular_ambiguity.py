"""scripts/specular_ambiguity.py: the specular lobes that photograph alike, and the bound on
the relit error they set, on cases whose answer is known."""

import importlib.util
import math

import numpy as np
import torch

from render.torch_renderer.renderer import ProbeBank
from tests.conftest import REPO

_spec = importlib.util.spec_from_file_location("specular_ambiguity",
                                               REPO / "scripts" / "specular_ambiguity.py")
ambiguity = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(ambiguity)

SUPPORT = ((0.02, 0.5), (math.log(0.01), math.log(1.0)))
"""Every alpha of the script's grid up to 0.5; relative specular albedo 0.01 to 1."""


def flat_truth(alpha, size=16):
    """A flat two-tone sample (relative albedo 0.3 and 0.7) with a grey specular lobe."""
    albedo = torch.full((1, 3, size, size), 0.3)
    albedo[..., size // 2:] = 0.7
    normal = torch.zeros(1, 3, size, size)
    normal[:, 2] = 1.0
    return {"albedo": albedo, "normal": normal,
            "log_specular": torch.full((1, 3), math.log(0.2)),
            "log_roughness": torch.tensor([[math.log(alpha)]])}


def probes():
    """Bank: 0, constant radiance; 1, a dim sky with a bright cap around the zenith, the
    direction a flat sample mirrors toward the camera above it."""
    constant = np.ones((32, 64, 3))
    spot = np.full((32, 64, 3), 0.2)
    spot[:2] = 200.0
    return ProbeBank([constant, spot])


def test_under_constant_light_every_lobe_looks_alike_and_relights_alike():
    """A constant environment reflects the same radiance from every direction: each alpha,
    with its specular albedo adjusted, photographs within one 8-bit level of the truth, and
    with the true albedo it relights like the truth under constant light again."""
    _, alternatives, _ = ambiguity.sample_alternatives(
        flat_truth(0.1), probes(), 0, torch.tensor([0]), torch.tensor([0.0]), SUPPORT, 1.0)
    assert {a["alpha"] for a in alternatives} == {a for a in ambiguity.ALPHAS if a <= 0.5}
    assert max(a["photo_levels"] for a in alternatives) < 1.0
    assert max(a["relit_rmse"] for a in alternatives if not a["albedo_free"]) < 2e-3
    assert ambiguity.roughness_unseen(alternatives, ambiguity.grid_alphas(SUPPORT), 1.0)


def test_glow_moved_into_the_albedo_changes_the_relative_scale():
    """Under constant light the specular glow and an albedo offset photograph alike, but a
    lighter albedo makes every relative quantity smaller (the mean albedo is the unit), so
    such a look-alike relights darker than the truth under the same light: the relative
    convention is part of what one photo cannot settle."""
    _, alternatives, bound = ambiguity.sample_alternatives(
        flat_truth(0.1), probes(), 0, torch.tensor([0]), torch.tensor([0.0]), SUPPORT, 1.0)
    moved = [a for a in alternatives if a["albedo_free"] and a["albedo_offset"] > 0.05]
    assert moved and all(a["photo_levels"] < 1.0 and a["relit_rmse"] > 5e-3 for a in moved)
    assert bound > 5e-3


def test_a_bright_zenith_in_the_new_light_separates_lobes_the_photo_could_not():
    """Photographed under constant light, a sharp and a broad lobe look alike; relit under a
    bright zenith cap, the sharp one mirrors the cap and the broad one spreads it, so no
    estimate can be close to both: the bound is large, and the sharpest look-alike relights
    far from the truth (alpha 0.3)."""
    _, alternatives, bound = ambiguity.sample_alternatives(
        flat_truth(0.3), probes(), 0, torch.tensor([1]), torch.tensor([0.0]), SUPPORT, 1.0)
    sharpest = next(a for a in alternatives if a["alpha"] == 0.02 and not a["albedo_free"])
    assert sharpest["photo_levels"] < 1.0
    assert sharpest["relit_rmse"] > 0.1
    assert bound > 0.05


def test_a_lobe_the_photo_shows_is_no_look_alike():
    """Photographed under the bright zenith cap, a sample whose upper half is tilted by 15
    degrees shows a sharp lobe as a bright flat half beside a dim tilted one, a broad lobe as
    two similar halves: whatever its specular albedo, and whatever the albedo (its two tones
    run across the tilt), the sharp lobe photographs levels away from the broad truth."""
    truth = flat_truth(0.3)
    tilt = math.radians(15.0)
    truth["normal"][:, 0, :8] = math.sin(tilt)
    truth["normal"][:, 2, :8] = math.cos(tilt)
    _, alternatives, _ = ambiguity.sample_alternatives(
        truth, probes(), 1, torch.tensor([1]), torch.tensor([90.0]), SUPPORT, 1.0)
    sharpest = [a for a in alternatives if a["alpha"] == 0.02]
    assert len(sharpest) == 2
    assert min(a["photo_levels"] for a in sharpest) > 1.0
    assert not ambiguity.roughness_unseen(alternatives, [0.02, 0.3], 1.0)
    assert ambiguity.roughness_unseen(alternatives, [0.3], 1.0)
