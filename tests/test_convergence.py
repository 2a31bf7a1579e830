"""Ground truth is converged: at the default sample count, at least 50 dB PSNR against a
render with 16 times the samples (auto-exposed, clamped images), on the bundled data."""

import numpy as np
import pytest

from render.common.exposure import exposure_scale
from render.common.probes import load_probe
from render.dataset.config import DatasetConfig
from render.materials.reduced_svbrdf import load_material, resample
from render.mitsuba_reference.scene import PlanarSampleRenderer
from tests.conftest import BUNDLED_MATERIALS, BUNDLED_PROBES


@pytest.mark.parametrize("material, probe", [("pbrone_bricks", "env-studio"),
                                             ("polyhaven_fabric_pattern_07", "park")])
def test_default_spp_is_converged(mi, material, probe):
    spp = DatasetConfig.spp
    renderer = PlanarSampleRenderer("llvm_ad_rgb", spp=spp)
    svbrdf = resample(load_material(BUNDLED_MATERIALS / material), 32)
    light = load_probe(BUNDLED_PROBES / f"{probe}.exr")
    image = renderer.render(svbrdf, light, 70.0, seed=1)
    reference = renderer.render(svbrdf, light, 70.0, seed=2, spp=16 * spp)
    scale = exposure_scale(reference)
    error = np.mean((np.clip(image * scale, 0, 1) - np.clip(reference * scale, 0, 1)) ** 2)
    assert 10 * np.log10(1 / error) >= 50.0
