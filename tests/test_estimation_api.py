"""The Python API of estimation (train.estimation.Estimator): what sa-estimate writes, as
arrays, and the README's example runs as printed."""

import re
import subprocess
import sys

import numpy as np
import pytest

from render.common.images import read_image
from tests.conftest import REPO
from train.cli.sa_estimate import main as sa_estimate
from train.estimation import Estimator

PHOTO = REPO / "scenes" / "photos" / "brick-reference-01.jpg"


@pytest.fixture(scope="module")
def estimator():
    return Estimator(material_class="wood", max_side=128)


def test_the_api_gives_what_sa_estimate_writes(estimator, tmp_path):
    result = estimator.estimate_file(PHOTO)
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as exit_code:
        sa_estimate([str(PHOTO), "--class", "wood", "--max-side", "128", "--out", str(out)])
    assert exit_code.value.code == 0
    folder = out / PHOTO.stem
    assert result.albedo.shape == (96, 128, 3) and result.albedo.dtype == np.float32
    np.testing.assert_array_equal(read_image(folder / "albedo.exr"), result.albedo)
    np.testing.assert_allclose(read_image(folder / "normal.exr") * 2.0 - 1.0, result.normal,
                               atol=1e-6)  # float32 rounding of the (n + 1) / 2 encoding
    np.testing.assert_allclose(np.linalg.norm(result.normal, axis=-1), 1.0, rtol=1e-5)
    assert 0.02 <= result.roughness <= 1.0 and result.specular_albedo.shape == (3,)
    assert result.network["model"].endswith("svbrdf-wood.safetensors")


def test_an_array_is_estimated_as_the_same_photo_read_from_a_file(estimator):
    from train.data.photos import read_linear_photo
    from_file = estimator.estimate_file(PHOTO)
    from_array = estimator.estimate(read_linear_photo(PHOTO).astype(np.float64))
    np.testing.assert_array_equal(from_file.albedo, from_array.albedo)
    assert from_file.roughness == from_array.roughness


@pytest.mark.parametrize("pixels, message", [
    (np.zeros((64, 64)), r"\(H, W, 3\) numpy array of linear RGB, got \(64, 64\)"),
    (np.zeros((64, 64, 3), np.uint8), "floating-point linear RGB, got uint8"),
    (np.zeros((8, 64, 3)), "photo is 64x8 pixels"),
    (np.full((64, 64, 3), np.nan), "NaN or infinite"),
])
def test_bad_arrays_get_one_clear_line(estimator, pixels, message):
    with pytest.raises(ValueError, match=message):
        estimator.estimate(pixels)


# The bundled brick photo holds a ColorChecker; its two lightest neutral patches, as (top,
# bottom, left, right) pixel boxes inside the patches of the 256 x 192 photo (looked up on it).
LIGHTEST_NEUTRAL_PATCHES = ((92, 101, 108, 117), (92, 101, 124, 135))


def chroma(pixels):
    """(max - min) / mean of the mean linear RGB colour of (h, w, 3) pixels."""
    colour = pixels.reshape(-1, 3).mean(0)
    return float((colour.max() - colour.min()) / colour.mean())


def test_the_default_estimate_keeps_neutral_patches_neutral():
    """The photo's own chroma of the patches is about 0.005; an albedo that turns them blue
    (0.3, what the general network of an earlier release gave, which its material classifier
    picked for this photo) fails."""
    from train.data.photos import read_linear_photo
    photo = read_linear_photo(PHOTO)
    albedo = Estimator().estimate(photo).albedo
    assert albedo.shape == photo.shape
    for top, bottom, left, right in LIGHTEST_NEUTRAL_PATCHES:
        assert chroma(photo[top:bottom, left:right]) < 0.01  # the boxes are on the patches
        assert chroma(albedo[top:bottom, left:right]) <= 0.05


def test_the_readme_example_runs():
    readme = (REPO / "README.md").read_text()
    section = readme[readme.index("### Python API"):]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    result = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True,
                            text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[0] == "(192, 256, 3) (192, 256, 3)"
    assert lines[1].split() == ["[", "0.08", "0.08", "0.08]", "0.25"]  # the fixed lobe
    assert lines[2].endswith("svbrdf-plastic.safetensors fixed")


def test_a_material_of_unknown_kind_gets_plastic_maps_with_the_fixed_lobe():
    """The default (--class unknown): the plastic network's albedo and normals, the naive
    baseline's lobe; --class plastic: the same maps with the lobe the network reads."""
    from train.estimation.network_choice import DEFAULT_CLASS, FIXED_ROUGHNESS, FIXED_SPECULAR
    assert DEFAULT_CLASS == "unknown"
    unknown = Estimator(max_side=128).estimate_file(PHOTO)
    plastic = Estimator(material_class="plastic", max_side=128).estimate_file(PHOTO)
    np.testing.assert_array_equal(unknown.albedo, plastic.albedo)
    np.testing.assert_array_equal(unknown.normal, plastic.normal)
    assert unknown.network == {"model": plastic.network["model"], "lobe": "fixed"}
    assert plastic.network["lobe"] == "read"
    np.testing.assert_array_equal(unknown.specular_albedo, np.full(3, FIXED_SPECULAR, np.float32))
    assert unknown.roughness == FIXED_ROUGHNESS
    assert abs(np.log(plastic.roughness / FIXED_ROUGHNESS)) > 0.05  # the reading differs
