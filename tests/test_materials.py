"""Material folders: naming schemes, material.json, the metallic-roughness -> Ward mapping."""

import json

import numpy as np
import pytest

from render.common.color import srgb_to_linear
from render.materials.map_names import is_directx_normal, map_role
from render.materials.reduced_svbrdf import ALPHA_RANGE, MIN_DIFFUSE_ALBEDO, load_material, resample
from tests.conftest import BUNDLED_MATERIALS, SHARED_DATA, make_material, needs_shared, write_png


@pytest.mark.parametrize("name, role", [
    ("aluminium_albedo.png", "albedo"), ("bricks_col.jpg", "albedo"),
    ("fabric_pattern_07_col_1_1k.jpg", "albedo"), ("brick_base_gray.jpg", "albedo"),
    ("wood_color.jpg", "albedo"), ("Metal_BaseColor_2K.png", "albedo"),
    ("bricks_nrm.jpg", "normal"), ("fabric_pattern_07_nor_gl_1k.jpg", "normal"),
    ("texture_rock_normal.png", "normal"), ("x_Normal-DX.png", "normal"),
    ("bricks_rgh.jpg", "roughness"), ("rock_rough.jpg", "roughness"),
    ("brick_roughness.jpg", "roughness"), ("sand_metal.jpg", "metallic"),
    ("x_metalness.png", "metallic"), ("fabric_pattern_07_arm_1k.jpg", "arm"),
    ("x_ao.png", "ignored"), ("x_height_4k.png", "ignored"), ("texture_bricks.jpg", None),
])
def test_map_roles(name, role):
    assert map_role(name) == role


def test_directx_names():
    assert is_directx_normal("rock_nor_dx_1k.png")
    assert not is_directx_normal("rock_nor_gl_1k.png")


def test_metallic_roughness_to_ward(tmp_path):
    color = np.full((8, 8, 3), [0.8, 0.5, 0.2])
    metal = np.zeros((8, 8))
    metal[:, :4] = 1.0  # left half metal, right half dielectric
    folder = make_material(tmp_path / "m", color, metallic=metal, roughness=np.full((8, 8), 0.6))
    svbrdf = load_material(folder)
    base = srgb_to_linear(np.round(np.array([0.8, 0.5, 0.2]) * 255) / 255)
    np.testing.assert_allclose(svbrdf.albedo[0, 0], MIN_DIFFUSE_ALBEDO, atol=1e-6)
    np.testing.assert_allclose(svbrdf.albedo[0, 7], base, atol=1e-5)
    np.testing.assert_allclose(svbrdf.specular, 0.5 * 0.04 + 0.5 * base, atol=1e-5)
    assert svbrdf.roughness == pytest.approx((round(0.6 * 255) / 255) ** 2, abs=1e-6)
    np.testing.assert_allclose(svbrdf.normal[..., 2], 1.0)  # missing normal map: flat


def test_normal_map_decoding_and_directx_flip(tmp_path):
    encoded = np.full((4, 4, 3), [0.5, 0.8, 0.9])
    gl = load_material(make_material(tmp_path / "gl", np.full((4, 4), 0.5), normal=encoded))
    folder = make_material(tmp_path / "dx", np.full((4, 4), 0.5), normal=encoded)
    (folder / "material.json").write_text(json.dumps({"normal_convention": "directx"}))
    dx = load_material(folder)
    np.testing.assert_allclose(np.linalg.norm(gl.normal, axis=-1), 1.0, rtol=1e-5)
    assert gl.normal[0, 0, 1] > 0.4 and dx.normal[0, 0, 1] == pytest.approx(-gl.normal[0, 0, 1])


def test_material_json_overrides(tmp_path):
    folder = make_material(tmp_path / "m", np.full((4, 4, 3), 0.5), roughness=np.ones((4, 4)))
    write_png(folder / "weird_name.png", np.full((4, 4, 3), 0.25))
    (folder / "material.json").write_text(json.dumps({
        "albedo": "weird_name.png", "specular_albedo": [0.1, 0.2, 0.3], "ward_roughness": 0.001,
        "albedo_color_space": "linear", "class": "plastic", "metadata": {"seed": 3}}))
    svbrdf = load_material(folder)
    np.testing.assert_allclose(svbrdf.albedo, 64 / 255, atol=1e-6)
    np.testing.assert_allclose(svbrdf.specular, [0.1, 0.2, 0.3], rtol=1e-6)
    assert svbrdf.roughness == ALPHA_RANGE[0]  # clamped to the supported range
    assert svbrdf.material_class == "plastic"


def test_arm_packing(tmp_path):
    arm = np.zeros((4, 4, 3))
    arm[..., 1], arm[..., 2] = 0.4, 1.0
    svbrdf = load_material(make_material(tmp_path / "m", np.full((4, 4, 3), 0.5), arm=arm))
    assert svbrdf.roughness == pytest.approx((round(0.4 * 255) / 255) ** 2, abs=1e-6)
    np.testing.assert_allclose(svbrdf.albedo, MIN_DIFFUSE_ALBEDO)  # fully metallic


def test_resample_keeps_aspect_and_unit_normals():
    svbrdf = load_material(BUNDLED_MATERIALS / "pbrone_bricks")
    small = resample(svbrdf, 48)
    assert small.albedo.shape == (48, 48, 3)
    np.testing.assert_allclose(np.linalg.norm(small.normal, axis=-1), 1.0, rtol=1e-5)
    assert abs(small.albedo.mean() - svbrdf.albedo.mean()) < 0.01


@needs_shared
def test_every_shared_material_loads(caplog):
    """Every real set loads, whatever its naming scheme: no map is left unrecognized, a set
    that has a normal map is read with it (not the flat default), and the values are in
    range."""
    folders = sorted(p for p in (SHARED_DATA / "svbrdfs").iterdir() if p.is_dir())
    assert folders, "no material sets in the shared data"
    for folder in folders:
        with caplog.at_level("WARNING"):
            svbrdf = load_material(folder)
        assert "unrecognized map name" not in caplog.text, (folder.name, caplog.text)
        assert svbrdf.albedo.shape[:2] == svbrdf.normal.shape[:2], folder.name
        assert ALPHA_RANGE[0] <= svbrdf.roughness <= ALPHA_RANGE[1], folder.name
        assert np.all(svbrdf.specular > 0) and np.all(svbrdf.albedo >= MIN_DIFFUSE_ALBEDO)
        np.testing.assert_allclose(np.linalg.norm(svbrdf.normal, axis=-1), 1.0, rtol=1e-4)
        normal_maps = [path.name for path in folder.iterdir() if map_role(path) == "normal"]
        if normal_maps:
            assert svbrdf.sources["normal"] in normal_maps, (folder.name, svbrdf.sources)


def test_unrecognized_images_are_reported_unless_material_json_names_the_maps(tmp_path, caplog):
    folder = make_material(tmp_path / "m", np.full((8, 8, 3), 0.5))
    write_png(folder / "relit-park.png", np.zeros((8, 8, 3)))
    with caplog.at_level("WARNING"):
        load_material(folder)
    assert "relit-park.png: unrecognized map name, ignored" in caplog.text
    caplog.clear()
    (folder / "material.json").write_text(json.dumps({"albedo": "m_albedo.png"}))
    with caplog.at_level("WARNING"):
        load_material(folder)
    assert caplog.text == ""
