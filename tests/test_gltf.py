"""material.glb: valid glTF 2.0 by the Khronos glTF-Validator, and the documented mapping of
the reduced SVBRDF read back from the file."""

import io
import json
import math
import shutil
import subprocess

import numpy as np
import pygltflib
import pytest
from PIL import Image

from render.common.color import to_png_bytes
from render.materials.gltf_file import DIELECTRIC_F0, write_gltf_file
from render.materials.reduced_svbrdf import ReducedSVBRDF
from tests.conftest import REPO

VALIDATOR = REPO / "scripts" / "validate_gltf.js"


def an_estimate(albedo_high=1.6, specular=(0.05, 0.3, 2.2), roughness=0.09):
    rng = np.random.default_rng(1)
    normal = rng.normal(size=(12, 20, 3))
    normal[..., 2] = np.abs(normal[..., 2]) + 2.0
    normal /= np.linalg.norm(normal, axis=2, keepdims=True)
    albedo = rng.uniform(0.05, albedo_high, (12, 20, 3))
    return ReducedSVBRDF("test", albedo.astype(np.float32), normal.astype(np.float32),
                         np.array(specular, np.float32), roughness)


def validate(*paths):
    """The glTF-Validator's reports, one per file."""
    if shutil.which("node") is None or not (REPO / "node_modules" / "gltf-validator").is_dir():
        pytest.fail("the glTF-Validator is not installed: run `make setup`")
    result = subprocess.run(["node", str(VALIDATOR), *map(str, paths)], capture_output=True,
                            text=True, timeout=120)
    return result.returncode, [json.loads(line) for line in result.stdout.splitlines()]


def texture_pixels(gltf, image_index):
    view = gltf.bufferViews[gltf.images[image_index].bufferView]
    data = gltf.binary_blob()[view.byteOffset:view.byteOffset + view.byteLength]
    return np.asarray(Image.open(io.BytesIO(data)))


def test_material_glb_passes_the_khronos_validator_without_errors_or_warnings(tmp_path):
    paths = [write_gltf_file(tmp_path / f"{i}.glb", an_estimate(roughness=alpha))
             for i, alpha in enumerate((0.02, 0.3, 1.0))]
    status, reports = validate(*paths)
    assert status == 0, reports
    assert [(r["numErrors"], r["numWarnings"]) for r in reports] == [(0, 0)] * 3, reports


def test_the_validator_reports_a_broken_file(tmp_path):
    path = write_gltf_file(tmp_path / "broken.glb", an_estimate())
    gltf = pygltflib.GLTF2.load_binary(str(path))
    gltf.materials[0].pbrMetallicRoughness.roughnessFactor = 1.5  # glTF allows [0, 1]
    gltf.save_binary(str(path))
    status, reports = validate(path)
    assert status == 1 and reports[0]["numErrors"] > 0


def test_the_file_holds_the_documented_mapping(tmp_path):
    svbrdf = an_estimate()
    gltf = pygltflib.GLTF2.load_binary(str(write_gltf_file(tmp_path / "m.glb", svbrdf)))
    material = gltf.materials[0]
    scale = 2.2  # the largest specular albedo: every albedo is divided by it
    assert material.pbrMetallicRoughness.metallicFactor == 0.0
    assert material.pbrMetallicRoughness.roughnessFactor == pytest.approx(math.sqrt(0.09))
    specular = material.extensions["KHR_materials_specular"]
    np.testing.assert_allclose(np.array(specular["specularColorFactor"]) * DIELECTRIC_F0 * scale,
                               svbrdf.specular, rtol=1e-6)
    base = texture_pixels(gltf, material.pbrMetallicRoughness.baseColorTexture.index)
    np.testing.assert_array_equal(base, to_png_bytes(svbrdf.albedo / scale))
    normal = texture_pixels(gltf, material.normalTexture.index) / 255.0 * 2.0 - 1.0
    np.testing.assert_allclose(normal, svbrdf.normal, atol=1.0 / 255.0 + 1e-6)
    # Row 0 of the maps is the top of the plane: v = 0 at the vertices of largest y.
    positions = np.frombuffer(gltf.binary_blob(), np.float32, 12,
                              gltf.bufferViews[gltf.accessors[0].bufferView].byteOffset)
    texcoords = np.frombuffer(gltf.binary_blob(), np.float32, 8,
                              gltf.bufferViews[gltf.accessors[3].bufferView].byteOffset)
    top = positions.reshape(4, 3)[:, 1] > 0
    assert np.all(texcoords.reshape(4, 2)[top, 1] == 0.0)
    # The plane has the maps' aspect (20 x 12 px), its longer side 1.
    np.testing.assert_allclose(np.abs(positions.reshape(4, 3)[:, :2]), [[0.5, 0.3]] * 4)
