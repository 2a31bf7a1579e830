"""Closed-form checks of the Mitsuba pipeline and its probes: known answers, not reference images.

Tolerances: Monte Carlo noise at the sample counts used here (measured: below 0.3% on image
means, about 1% per pixel), plus float16-free float32 arithmetic.
"""

import numpy as np
import pytest

from render.common.probes import (Probe, find_probes, load_probe, pixel_directions,
                                  plane_irradiance, tilted)
from render.materials.reduced_svbrdf import ReducedSVBRDF
from render.mitsuba_reference.scene import PlanarSampleRenderer
from tests.conftest import BUNDLED_PROBES, make_probe

SIZE = 16


def flat_material(albedo, specular=0.0, roughness=0.3, normal=(0.0, 0.0, 1.0)):
    albedo = np.broadcast_to(np.asarray(albedo, np.float32), (SIZE, SIZE, 3)).copy()
    normal = np.asarray(normal, np.float32) / np.linalg.norm(normal)
    return ReducedSVBRDF("test", albedo, np.broadcast_to(normal, (SIZE, SIZE, 3)).copy(),
                         np.full(3, specular, np.float32), roughness)


def test_white_lambertian_under_constant_probe_reflects_one(renderer):
    probe = Probe("constant", None, np.ones((32, 64, 3), np.float32), np.ones(3))
    image = renderer.render(flat_material(1.0), probe, rotation_deg=33.0, seed=3)
    np.testing.assert_allclose(image, 1.0, atol=5e-3)
    np.testing.assert_allclose(image.mean(), 1.0, atol=5e-4)


def test_white_balance_makes_irradiance_neutral(renderer, tmp_path):
    tinted = load_probe(BUNDLED_PROBES / "park.exr").radiance * np.array([3.0, 1.0, 0.2])
    probe = load_probe(make_probe(tmp_path / "tinted.exr", tinted))
    np.testing.assert_allclose(plane_irradiance(probe.radiance), np.pi, rtol=1e-6)
    image = renderer.render(flat_material(1.0), probe, rotation_deg=120.0, seed=5, spp=1024)
    means = image.reshape(-1, 3).mean(0)
    np.testing.assert_allclose(means, 1.0, rtol=5e-3)
    assert means.max() / means.min() < 1.003


def test_zero_specular_equals_diffuse_only(renderer):
    """Flat normals, rho_s = 0: the radiance is albedo * E / pi = albedo, pixel for pixel
    (this also pins the texture orientation: an asymmetric albedo must come out unmoved)."""
    probe = load_probe(BUNDLED_PROBES / "park.exr")
    albedo = np.random.default_rng(0).uniform(0.05, 1.0, (SIZE, SIZE, 3)).astype(np.float32)
    albedo[:4, :6] = 1.0
    material = flat_material(0.5)
    material = ReducedSVBRDF("tex", albedo, material.normal, material.specular, 0.3)
    image = renderer.render(material, probe, rotation_deg=10.0, seed=7, spp=1024)
    relative = np.abs(image / albedo - 1)
    assert relative.mean() < 5e-3
    assert relative.max() < 3e-2


def test_specular_adds_light(renderer):
    probe = load_probe(BUNDLED_PROBES / "park.exr")
    diffuse = renderer.render(flat_material(0.5), probe, seed=1).mean()
    glossy = renderer.render(flat_material(0.5, specular=0.3), probe, seed=1).mean()
    assert glossy > diffuse * 1.05


def _patch_probe(column_fraction):
    """A dim probe with a bright patch 45 degrees above the horizon at one azimuth."""
    radiance = np.full((64, 128, 3), 0.01, np.float32)
    column = int(column_fraction * 128)
    radiance[14:18, [(column + d) % 128 for d in range(-2, 2)]] = 50.0
    return Probe("patch", None, radiance, np.ones(3))


@pytest.mark.parametrize("column_fraction, toward, rotation, brighter", [
    (0.0, (1, 0), 0.0, True),      # azimuth 0 is +x
    (0.0, (1, 0), 180.0, False),   # rotating the probe by 180 degrees moves the light to -x
    (0.75, (0, 1), 0.0, True),     # azimuth +90 degrees (+y, image up) is column 3W/4
    (0.75, (1, 0), 90.0, False),   # counter-clockwise rotation by 90 degrees moves it to -x
    (0.75, (-1, 0), 90.0, True),
])
def test_probe_and_normal_orientation(renderer, column_fraction, toward, rotation, brighter):
    probe = _patch_probe(column_fraction)
    tilt = (0.6 * toward[0], 0.6 * toward[1], 0.8)
    flat = renderer.render(flat_material(0.5), probe, rotation, seed=2).mean()
    tilted = renderer.render(flat_material(0.5, normal=tilt), probe, rotation, seed=2).mean()
    assert (tilted > 1.2 * flat) if brighter else (tilted < 0.8 * flat)


def test_a_reused_renderer_renders_what_a_fresh_one_does(mi):
    """The renderer keeps one scene per image size and updates its parameters; every input
    (textures, probe, rotation, view, specular, roughness, strips) must reach the render."""
    rng = np.random.default_rng(3)
    probes = [load_probe(path) for path in find_probes(BUNDLED_PROBES)][:2]

    def material(name, roughness):
        normal = rng.normal(size=(24, 16, 3)) * [0.3, 0.3, 1.0] + [0.0, 0.0, 2.0]
        return ReducedSVBRDF(name, rng.uniform(0.05, 0.9, (24, 16, 3)).astype(np.float32),
                             (normal / np.linalg.norm(normal, axis=2, keepdims=True))
                             .astype(np.float32), rng.uniform(0.02, 0.5, 3).astype(np.float32),
                             roughness)

    first, second = material("a", 0.3), material("b", 0.6)  # one sample split: one scene
    reused = PlanarSampleRenderer("llvm_ad_rgb", spp=64)
    reused.lane_budget = 64 * 16 * 5  # strips of 5 rows, the last one 4
    reused.render(first, probes[0], 10.0, view=(0.0, 0.0, 1.0), seed=1)
    image = reused.render(second, probes[1], 70.0, view=(0.2, -0.1, 1.0), seed=2)
    fresh = PlanarSampleRenderer("llvm_ad_rgb", spp=64)
    fresh.lane_budget = reused.lane_budget
    expected = fresh.render(second, probes[1], 70.0, view=(0.2, -0.1, 1.0), seed=2)
    np.testing.assert_array_equal(image, expected)
    assert not np.array_equal(image, fresh.render(first, probes[0], 10.0, seed=1))
    # Strips hold their own rows: the image matches one rendered whole, up to noise.
    whole = PlanarSampleRenderer("llvm_ad_rgb", spp=64).render(
        second, probes[1], 70.0, view=(0.2, -0.1, 1.0), seed=2)
    assert np.abs(image - whole).mean() < 0.2 * whole.mean()  # 0.45 with strips misplaced


def _sphere_moments(radiance):
    """Total energy over the sphere (solid-angle weighted) and the energy-weighted mean
    direction of a probe's radiance (first channel)."""
    height, width = radiance.shape[:2]
    solid_angle = np.sin(np.pi * np.arange(height) / (height - 1))[:, None]
    energy = radiance[..., 0] * solid_angle
    mean = (pixel_directions(height, width) * energy[..., None]).sum((0, 1)) / energy.sum()
    return energy.sum(), mean / np.linalg.norm(mean)


def test_a_tilted_probe_moves_its_lamp_by_the_tilt_and_keeps_its_energy():
    """A small lamp at 30 degrees from the zenith on a dim sky, tilted 40 degrees about the
    horizontal axis at azimuth 70: the lamp lands where that rotation takes its direction (to
    within a degree), the energy over the sphere stays (to 1%), and tilting back returns it."""
    height, width = 96, 192
    directions = pixel_directions(height, width)
    lamp = np.array([np.sin(np.radians(30)), 0.0, np.cos(np.radians(30))])
    radiance = 0.01 + 50.0 * np.exp((directions @ lamp - 1.0) / 0.002)
    radiance = np.repeat(radiance[..., None], 3, axis=2).astype(np.float32)
    axis = np.array([np.cos(np.radians(70)), np.sin(np.radians(70)), 0.0])
    angle = np.radians(40)
    expected = (np.cos(angle) * lamp + np.sin(angle) * np.cross(axis, lamp)
                + (1 - np.cos(angle)) * (axis @ lamp) * axis)

    energy, _ = _sphere_moments(radiance - 0.01)
    turned = tilted(radiance, 40.0, 70.0)
    turned_energy, turned_direction = _sphere_moments(turned - 0.01)
    assert np.degrees(np.arccos(turned_direction @ expected)) < 1.0
    assert turned_energy == pytest.approx(energy, rel=0.01)
    _, back = _sphere_moments(tilted(turned, -40.0, 70.0) - 0.01)
    assert np.degrees(np.arccos(back @ lamp)) < 1.0
    np.testing.assert_allclose(tilted(radiance, 0.0, 70.0)[1:], radiance[1:], atol=1e-5)
