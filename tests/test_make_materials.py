"""make-materials: valid ranges, unit normals, seamless tiling, determinism, resume, augmentation,
and that render-dataset accepts every class."""

import json
from dataclasses import replace

import numpy as np
import pytest
from click.testing import CliRunner

from render.cli.make_materials import main as make_materials
from render.cli.render_dataset import main as render_dataset
from render.materials.procedural.augment import augment, material_class_of, sample_augmentation
from render.materials.procedural.material_set import GENERATORS, draw_metadata, regenerate
from render.materials.procedural.noise import cellular, gaussian_noise
from render.materials.procedural.palette import measured, plastics
from render.materials.procedural.surface import height_to_normal
from render.materials.reduced_svbrdf import (ALPHA_RANGE, MIN_DIFFUSE_ALBEDO, ReducedSVBRDF,
                                             load_material)
from tests.conftest import BUNDLED_MATERIALS, BUNDLED_PROBES, SHARED_DATA, needs_shared

CLASSES = sorted(GENERATORS)
SEEDS = range(6)


def generated(material_class, index, size=96, seed=0):
    return regenerate(draw_metadata(material_class, seed, index, size))


def make(out, *options):
    result = CliRunner().invoke(make_materials, ["--out", str(out), *options])
    return result


def summary(result):
    """The JSON summary that make-materials prints last on standard output."""
    return json.loads(result.stdout.strip().splitlines()[-1])


def wrap_is_seamless(pixels):
    """The jump across the tile's wrapped edges is no larger than the jumps inside the tile.

    Per axis, the mean absolute difference between the last and first line must not exceed four
    times the mean difference between neighbouring lines inside (the 99th percentile, so that
    plank seams inside do not hide a jump at the edge)."""
    for axis in (0, 1):
        lines = np.moveaxis(np.asarray(pixels, np.float64), axis, 0)
        inside = np.abs(np.diff(lines, axis=0)).reshape(lines.shape[0] - 1, -1).mean(1)
        wrap = np.abs(lines[0] - lines[-1]).mean()
        if wrap > 4.0 * np.percentile(inside, 99) + 1e-6:
            return False
    return True


@pytest.mark.parametrize("material_class", CLASSES)
def test_maps_are_in_range_with_unit_normals(material_class):
    for index in SEEDS:
        svbrdf = generated(material_class, index)
        assert svbrdf.albedo.shape == (96, 96, 3) and svbrdf.normal.shape == (96, 96, 3)
        assert np.isfinite(svbrdf.albedo).all() and np.isfinite(svbrdf.normal).all()
        assert svbrdf.albedo.min() >= MIN_DIFFUSE_ALBEDO and svbrdf.albedo.max() <= 1.0
        assert np.allclose(np.linalg.norm(svbrdf.normal, axis=-1), 1.0, atol=1e-5)
        assert svbrdf.normal[..., 2].min() > 0.2
        assert (svbrdf.specular > 0).all() and (svbrdf.specular <= 1).all()
        assert ALPHA_RANGE[0] <= svbrdf.roughness <= ALPHA_RANGE[1]
        assert svbrdf.material_class == material_class


def test_class_specific_specular():
    plastic_f0 = [((p.ior - 1) / (p.ior + 1)) ** 2 for p in plastics()]
    for index in SEEDS:
        wood, plastic = generated("wood", index, 32), generated("plastic", index, 32)
        assert np.allclose(wood.specular, 0.04, atol=1e-6)
        assert min(plastic_f0) - 1e-6 <= plastic.specular[0] <= max(plastic_f0) + 1e-6
        assert plastic.specular[0] == plastic.specular[1] == plastic.specular[2]
        assert plastic.roughness <= 0.55 ** 2 + 0.35  # low to medium, scratches included
        metadata = draw_metadata("metal", 0, index, 32)
        metal = regenerate(metadata)
        if metadata["parameters"]["finish"] != "corroded":  # rust lowers the mean F0
            assert np.allclose(metal.specular, np.clip(measured(
                metadata["parameters"]["metal"]).color, 0, 1), atol=1e-6)
        assert metal.albedo.mean() < 0.3 * metal.specular.mean()  # dark diffuse


@pytest.mark.parametrize("material_class", CLASSES)
def test_maps_tile_seamlessly(material_class):
    for index in SEEDS:
        svbrdf = generated(material_class, index, size=128)
        assert wrap_is_seamless(svbrdf.albedo), (material_class, index)
        assert wrap_is_seamless(svbrdf.normal), (material_class, index)


def test_the_seam_check_can_fail():
    field = gaussian_noise(160, 3, 1, 6)
    assert wrap_is_seamless(field)
    assert not wrap_is_seamless(field[:110, :110])


def test_noise_is_periodic_unit_variance_and_resolution_independent():
    fine, coarse = gaussian_noise(128, 5, 2, 12), gaussian_noise(64, 5, 2, 12)
    assert abs(fine.std() - 1) < 0.2 and abs(fine.mean()) < 0.2
    assert np.isclose(fine.std(), coarse.std(), rtol=1e-4)  # same function, other sampling
    assert np.abs(fine.reshape(64, 2, 64, 2).mean((1, 3)) - coarse).max() < 0.1
    streaks = gaussian_noise(128, 5, 4, 60, stretch=30.0, angle_deg=0.0)  # along image x
    along = np.abs(np.diff(streaks, axis=1)).mean()
    across = np.abs(np.diff(streaks, axis=0)).mean()
    assert along < 0.3 * across
    nearest, second, _ = cellular(64, 1, 50)
    assert (nearest <= second).all() and nearest.max() < 0.5


def test_height_to_normal_matches_the_slope_of_a_sine():
    size, amplitude = 256, 0.01
    x = (np.arange(size) + 0.5) / size
    height = np.broadcast_to(amplitude * np.sin(2 * np.pi * 3 * x), (size, size))
    normal = height_to_normal(height)
    slope = amplitude * 2 * np.pi * 3 * np.cos(2 * np.pi * 3 * x)  # dh/dx, x toward the right
    expected_x = -slope / np.sqrt(1 + slope ** 2)
    assert np.abs(normal[0, :, 0] - expected_x).max() < 1e-3
    assert np.abs(normal[..., 1]).max() < 1e-6
    rising_upward = height_to_normal(np.ascontiguousarray(height.T[::-1]))  # h grows toward up
    assert np.abs(rising_upward[:, 0, 1] - expected_x).max() < 1e-3


@pytest.mark.parametrize("material_class", CLASSES)
def test_same_parameters_same_maps(material_class):
    first, second = generated(material_class, 2, 64), generated(material_class, 2, 64)
    assert np.array_equal(first.albedo, second.albedo)
    assert np.array_equal(first.normal, second.normal)
    other = generated(material_class, 3, 64)
    assert not np.array_equal(first.albedo, other.albedo)
    assert draw_metadata(material_class, 0, 2, 64) != draw_metadata(material_class, 1, 2, 64)


def test_cli_writes_sets_render_dataset_reads_back_and_reruns_resume(tmp_path):
    result = make(tmp_path / "a", "--class", "wood", "--count", "3", "--resolution", "48")
    assert result.exit_code == 0, result.output
    assert summary(result)["written"] == 3
    folders = sorted(p for p in (tmp_path / "a").iterdir() if p.is_dir())
    assert [p.name for p in folders] == ["wood_s0_0000", "wood_s0_0001", "wood_s0_0002"]
    assert (tmp_path / "a" / "contact_sheet_wood.png").is_file()

    metadata = json.loads((folders[1] / "material.json").read_text())["metadata"]
    expected = regenerate(metadata)
    loaded = load_material(folders[1])
    assert np.array_equal(loaded.albedo, expected.albedo)
    assert np.abs(loaded.normal - expected.normal).max() < 1e-5
    assert np.allclose(loaded.specular, expected.specular) and loaded.material_class == "wood"
    assert np.isclose(loaded.roughness, expected.roughness)

    more = make(tmp_path / "a", "--class", "wood", "--count", "4", "--resolution", "48")
    assert summary(more)["already_there"] == 3
    again = make(tmp_path / "b", "--class", "wood", "--count", "4", "--resolution", "48")
    for name in ("wood_s0_0000", "wood_s0_0003"):
        for file in ("albedo.exr", "normal.exr", "material.json"):
            assert (tmp_path / "a" / name / file).read_bytes() == \
                (tmp_path / "b" / name / file).read_bytes(), again.output
    refused = make(tmp_path / "a", "--class", "wood", "--count", "2", "--resolution", "64")
    assert refused.exit_code != 0 and "other options (differing: resolution)" in refused.output


def test_render_dataset_accepts_every_class(tmp_path):
    for material_class in CLASSES:
        result = make(tmp_path / "maps", "--class", material_class, "--count", "1",
                      "--resolution", "32")
        assert result.exit_code == 0, result.output
    result = CliRunner().invoke(render_dataset, [
        "--probes", str(BUNDLED_PROBES), "--svbrdfs", str(tmp_path / "maps"), "--out",
        str(tmp_path / "ds"), "--resolution", "16", "--render-size", "24", "--rotations", "1",
        "--crops", "1", "--spp", "16", "--test-materials", "0", "--test-probes", "0"])
    assert result.exit_code == 0, result.output
    index = json.loads((tmp_path / "ds" / "index.json").read_text())
    assert {s["material_class"] for s in index["samples"]} == set(CLASSES)
    assert index["count"] == len(CLASSES) * len(list(BUNDLED_PROBES.glob("*.exr")))


def synthetic_set(name, color, specular, roughness, size=40, material_class="metal"):
    albedo = np.broadcast_to(np.float32(color), (size, size, 3)).copy()
    normal = np.zeros((size, size, 3), np.float32)
    normal[..., 2] = 1
    return ReducedSVBRDF(name, albedo, normal, np.float32(specular), roughness, {},
                         material_class)


def test_augmentation_blends_recolors_and_is_recorded():
    sources = {"steel_plate": synthetic_set("steel_plate", (0.02, 0.02, 0.02), (0.6,) * 3, 0.1),
               "brass_sheet": synthetic_set("brass_sheet", (0.03, 0.03, 0.01), (0.9, 0.8, 0.4),
                                            0.3)}
    blended = None
    for index in range(40):
        parameters = sample_augmentation(np.random.default_rng(index), "metal", sorted(sources))
        svbrdf = augment(parameters, sources, 24, "aug", "metal")
        assert svbrdf.albedo.shape == (24, 24, 3) and svbrdf.material_class == "metal"
        assert np.allclose(svbrdf.specular, measured(parameters["recolor"]["metal"]).specular)
        assert svbrdf.albedo.max() < 0.2  # a dark film stays dark whatever the new metal
        assert np.array_equal(svbrdf.albedo, augment(parameters, sources, 24, "aug",
                                                     "metal").albedo)
        if "blend" in parameters:
            blended = svbrdf
            assert 0.1 - 1e-6 <= svbrdf.roughness <= 0.3 + 1e-6
            assert set(svbrdf.sources["augmented from"]) == set(sources)
    assert blended is not None


def test_a_metal_set_reduced_as_a_dielectric_becomes_a_dark_film():
    aluminium = synthetic_set("aluminium", (0.45, 0.45, 0.45), (0.04,) * 3, 0.25)
    parameters = sample_augmentation(np.random.default_rng(0), "metal", ["aluminium"])
    svbrdf = augment(parameters, {"aluminium": aluminium}, 24, "aug", "metal")
    film = parameters["recolor"]["film"]
    assert svbrdf.albedo.mean() < 0.45 * film * 1.6
    assert svbrdf.specular.mean() > 0.3


def test_augmentation_turns_normals_with_the_picture():
    source = synthetic_set("oak", (0.3, 0.2, 0.1), (0.04,) * 3, 0.2, material_class="wood")
    normal = source.normal.copy()
    normal[..., 0] = 0.6  # tilted toward image right
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    source = replace(source, normal=normal)
    parameters = {"source": "oak", "crop": {"fraction": 1.0, "top": 0.0, "left": 0.0},
                  "quarter_turns": 1, "recolor": {"lightness": 1.0, "chroma": 1.0, "hue_deg": 0.0}}
    turned = augment(parameters, {"oak": source}, 40, "aug", "wood")
    assert np.allclose(turned.normal[..., 1], normal[..., 0], atol=1e-5)  # right -> up
    assert np.allclose(turned.albedo, source.albedo, atol=2e-3)


def test_cli_augments_the_bundled_wood_and_refuses_a_class_without_sets(tmp_path):
    result = make(tmp_path / "aug", "--class", "wood", "--count", "2", "--resolution", "32",
                  "--augment", str(BUNDLED_MATERIALS))
    assert result.exit_code == 0, result.output
    loaded = load_material(tmp_path / "aug" / "wood_aug_s0_0000")
    metadata = json.loads((tmp_path / "aug" / "wood_aug_s0_0000" / "material.json").read_text())
    assert metadata["metadata"]["augmentation"]["source"] == "godot_texture_wood"
    assert loaded.material_class == "wood"
    refused = make(tmp_path / "aug", "--class", "metal", "--count", "1", "--augment",
                   str(BUNDLED_MATERIALS))
    assert refused.exit_code != 0 and "no metal set" in refused.output


def test_bad_options_fail_before_anything_is_written(tmp_path):
    not_a_probe = make(tmp_path / "out", "--class", "metal", "--probe",
                       str(BUNDLED_PROBES / "CREDITS.md"))
    assert not_a_probe.exit_code != 0 and "CREDITS.md" in not_a_probe.output
    assert not (tmp_path / "out").exists()
    assert make(tmp_path / "out", "--class", "metal", "--count", "0").exit_code != 0
    assert make(tmp_path / "out", "--class", "stone").exit_code != 0


@needs_shared
def test_real_shared_sets_are_classified_by_name():
    classes = {path.name: material_class_of(load_material(path))
               for path in sorted((SHARED_DATA / "svbrdfs").iterdir()) if path.is_dir()}
    assert classes["godot_texture_wood"] == classes["materialx_wood"] == "wood"
    assert classes["godot_aluminium"] == "metal"
    assert classes["pbrone_bricks"] is None
