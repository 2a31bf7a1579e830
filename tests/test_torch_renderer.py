"""The torch renderer: closed forms, conventions, gradients, and agreement with Mitsuba."""

import numpy as np
import pytest
import torch
from click.testing import CliRunner

from render.common.exposure import expose, expose_numpy
from render.torch_renderer.renderer import ProbeBank, render, sphere_normals
from tests.conftest import BUNDLED_MATERIALS, BUNDLED_PROBES

ROUGHNESS = [0.02, 0.05, 0.1, 0.2, 0.5, 1.0]


def constant_bank(height=64, dtype=torch.float64):
    return ProbeBank([np.ones((height, 2 * height, 3))], dtype=dtype)


def tilted_normals(angles_deg, dtype=torch.float64):
    """(1, 3, 1, N) normals tilted from +z toward +x by the given angles."""
    theta = torch.deg2rad(torch.tensor(angles_deg, dtype=dtype))
    return torch.stack([torch.sin(theta), torch.zeros_like(theta), torch.cos(theta)])[None, :, None]


def ward_integral_top_view(alpha, steps=20000):
    """Integral of the Ward lobe times cosine over the hemisphere, flat normal, view +z,
    constant unit radiance (1D in theta by symmetry)."""
    theta = (np.arange(steps) + 0.5) * (np.pi / 2 / steps)
    cos_h = np.cos(theta / 2)
    lobe = np.exp((1 - 1 / cos_h ** 2) / alpha ** 2) / (4 * np.pi * alpha ** 2)
    return float(np.sum(lobe * np.sqrt(np.cos(theta)) * np.sin(theta)) * np.pi / steps * np.pi)


def test_white_lambertian_under_constant_probe_is_one():
    normal = tilted_normals([0.0] * 4)
    out = render(torch.ones(1, 3, 1, 4, dtype=torch.float64), normal,
                 torch.zeros(1, 3, dtype=torch.float64), torch.tensor([0.3], dtype=torch.float64),
                 constant_bank(), [0])
    assert torch.allclose(out, torch.ones_like(out), rtol=1e-3)


def test_tilted_lambertian_sees_only_the_sky():
    """Uniform sky above the plane: a normal tilted by t receives pi (1 + cos t) / 2."""
    angles = [0.0, 20.0, 45.0, 70.0, 85.0]
    out = render(torch.ones(1, 3, 1, 5, dtype=torch.float64), tilted_normals(angles),
                 torch.zeros(1, 3, dtype=torch.float64), torch.tensor([0.3], dtype=torch.float64),
                 constant_bank(), [0])
    expected = (1 + np.cos(np.radians(angles))) / 2
    np.testing.assert_allclose(out[0, 0, 0].numpy(), expected, rtol=5e-3)


@pytest.mark.parametrize("alpha", [0.02, 0.05, 0.1, 0.2, 0.3, 1.0])
def test_ward_lobe_under_constant_probe_matches_quadrature(alpha):
    out = render(torch.zeros(1, 3, 2, 2, dtype=torch.float64),
                 tilted_normals([0.0, 0.0]).expand(1, 3, 2, 2),
                 torch.ones(1, 3, dtype=torch.float64), torch.tensor([alpha], dtype=torch.float64),
                 constant_bank(256), [0])
    assert out[0, 0, 0, 0].item() == pytest.approx(ward_integral_top_view(alpha), rel=0.01)


def test_quarter_turn_of_probe_equals_quarter_turn_of_sample():
    """Turning the whole scene, sample (maps and normal vectors) and probe, a quarter turn
    clockwise turns the render with it, exactly."""
    rng = np.random.default_rng(1)
    normal = rng.normal(size=(8, 8, 3)) * [0.3, 0.3, 0] + [0, 0, 1]
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    albedo = rng.uniform(0.1, 0.9, (8, 8, 3))
    turned_albedo = np.rot90(albedo, -1)
    n = np.rot90(normal, -1)
    turned_normal = np.stack([n[..., 1], -n[..., 0], n[..., 2]], -1)  # (x, y) -> (y, -x)
    probe = rng.uniform(0, 1, (32, 64, 3)) ** 4
    bank = ProbeBank([probe], dtype=torch.float64)

    def draw(a, nrm, rotation, alpha):
        t = torch.from_numpy(np.stack([np.ascontiguousarray(a), np.ascontiguousarray(nrm)]))
        return render(t[:1].permute(0, 3, 1, 2), t[1:].permute(0, 3, 1, 2),
                      torch.full((1, 3), 0.5, dtype=torch.float64),
                      torch.tensor([alpha], dtype=torch.float64), bank, [0],
                      torch.tensor([rotation], dtype=torch.float64))[0].permute(1, 2, 0).numpy()

    for alpha in (0.05, 0.5):
        reference = np.rot90(draw(albedo, normal, 30.0, alpha), -1)
        turned = draw(turned_albedo, turned_normal, 30.0 - 90.0, alpha)
        np.testing.assert_allclose(turned, reference, rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize("alpha", [0.05, 0.45])
def test_gradients_match_finite_differences(alpha):
    """Float64 gradcheck of the maps, the specular albedo and the roughness, for a sharp lobe
    (half-vector lattice) and a broad one (probe blocks). The table spacing jumps where it
    crosses a quarter octave (alpha = 0.5 is such a point), so both alphas lie inside one."""
    rng = np.random.default_rng(2)
    bank = ProbeBank([rng.uniform(0, 1, (16, 32, 3)) ** 3], dtype=torch.float64)
    normal = rng.normal(size=(1, 3, 3, 3)) * np.array([0.2, 0.2, 0])[None, :, None, None]
    normal[:, 2] += 1
    inputs = (torch.tensor(rng.uniform(0.2, 0.8, (1, 3, 3, 3)), requires_grad=True),
              torch.tensor(normal, requires_grad=True),
              torch.tensor([[0.3, 0.4, 0.5]], dtype=torch.float64, requires_grad=True),
              torch.tensor([alpha], dtype=torch.float64, requires_grad=True))

    def function(albedo, normal, specular, roughness):
        return render(albedo, normal, specular, roughness, bank, [0],
                      torch.tensor([15.0], dtype=torch.float64))

    assert torch.autograd.gradcheck(function, inputs, eps=1e-7, atol=1e-5, rtol=1e-3)


def test_recomputed_tables_give_the_same_gradients(monkeypatch):
    """Beyond KEPT_LANES the sharp tables are recomputed in the backward pass rather than
    kept (memory); the values and gradients must be those of the kept path."""
    from render.torch_renderer import renderer
    rng = np.random.default_rng(3)
    bank = ProbeBank([rng.uniform(0, 1, (16, 32, 3)) ** 3], dtype=torch.float64)
    normal = rng.normal(size=(1, 3, 8, 8)) * np.array([0.5, 0.5, 0])[None, :, None, None]
    normal[:, 2] += 1
    maps = (rng.uniform(0.2, 0.8, (1, 3, 8, 8)), normal, [[0.3, 0.4, 0.5]], [0.05])

    def image_and_gradients():
        inputs = [torch.tensor(np.asarray(m, np.float64), requires_grad=True) for m in maps]
        image = render(*inputs, bank, [0], torch.tensor([15.0], dtype=torch.float64))
        (image * torch.linspace(0, 1, image.numel(), dtype=torch.float64).reshape(
            image.shape)).sum().backward()
        return [image.detach()] + [tensor.grad for tensor in inputs]

    kept = image_and_gradients()
    calls = []
    monkeypatch.setattr(renderer, "KEPT_LANES", 0)
    monkeypatch.setattr(renderer, "checkpoint",
                        lambda *a, **k: calls.append(1) or torch.utils.checkpoint.checkpoint(
                            *a, **k))
    recomputed = image_and_gradients()
    assert calls  # the recomputing path ran
    for a, b in zip(kept, recomputed):
        torch.testing.assert_close(a, b, rtol=1e-12, atol=1e-15)


def test_sphere_is_a_normal_map():
    normal, mask = sphere_normals(32, dtype=torch.float64)
    assert torch.allclose(normal.norm(dim=0), torch.ones(32, 32, dtype=torch.float64))
    out = render(torch.ones(1, 3, 32, 32, dtype=torch.float64), normal[None],
                 torch.zeros(1, 3, dtype=torch.float64), torch.tensor([0.3], dtype=torch.float64),
                 constant_bank(), [0])[0, 0]
    expected = (1 + normal[2]) / 2
    inside = mask[0] > 0
    assert torch.allclose(out[inside], expected[inside], rtol=5e-3)
    glossy = render(torch.zeros(1, 3, 32, 32, dtype=torch.float64), normal[None],
                    torch.ones(1, 3, dtype=torch.float64),
                    torch.tensor([0.02], dtype=torch.float64), constant_bank(), [0])
    assert torch.isfinite(glossy).all()


def test_exposure_matches_the_dataset_pipeline():
    hdr = np.random.default_rng(3).uniform(0, 4, (2, 16, 16, 3)).astype(np.float32)
    ours = expose(torch.from_numpy(hdr).permute(0, 3, 1, 2)).permute(0, 2, 3, 1).numpy()
    for image, exposed in zip(hdr, ours):
        np.testing.assert_allclose(exposed, expose_numpy(image)[0], atol=1e-6)


def test_probes_of_one_bank_must_share_a_size():
    with pytest.raises(ValueError, match="share a size"):
        ProbeBank([np.ones((8, 16, 3)), np.ones((16, 32, 3))])


def flat_inputs(batch=2, size=4):
    """Valid render inputs: grey albedo, flat normals, specular 0.04, roughness 0.2."""
    return (torch.full((batch, 3, size, size), 0.5), tilted_normals([0.0] * size, torch.float32)
            .expand(batch, 3, size, size), torch.full((batch, 3), 0.04), torch.full((batch,), 0.2))


@pytest.mark.parametrize("change, message", [
    (lambda a, n, s, r: (a.permute(0, 2, 3, 1), n, s, r),
     r"albedo must be \(B, 3, H, W\), got shape \(2, 4, 4, 3\)"),
    (lambda a, n, s, r: (a, n[:, :, :2], s, r), r"normal must have the albedo's shape"),
    (lambda a, n, s, r: (a, n, s[:, :1], r), r"specular must be \(2, 3\), got shape \(2, 1\)"),
    (lambda a, n, s, r: (a, n, s, r[:1]), r"roughness must hold 2 values"),
    (lambda a, n, s, r: (a, n, s, torch.tensor([0.2, 0.001])),
     r"Ward roughness must lie in \[0.02, 1.0\], got values from 0.001 to 0.2"),
    (lambda a, n, s, r: (a, n, s, torch.tensor([0.2, float("nan")])), r"Ward roughness"),
])
def test_render_refuses_bad_inputs_naming_them(change, message):
    with pytest.raises(ValueError, match=message):
        render(*change(*flat_inputs()), constant_bank(16, torch.float32), [0, 0])
    with pytest.raises(ValueError, match=r"probe_index must be \(2,\) indices into a bank of 1"):
        render(*flat_inputs(), constant_bank(16, torch.float32), [0, 1])


def test_expose_refuses_black_and_misshaped_images():
    images = torch.ones(3, 3, 4, 4)
    images[1] = 0
    with pytest.raises(ValueError, match=r"cannot expose images \[1\]: mean luminance \[0.0\]"):
        expose(images)
    with pytest.raises(ValueError, match=r"expose takes \(B, 3, H, W\) images"):
        expose(images.permute(0, 2, 3, 1))


@pytest.mark.skipif(not torch.cuda.is_available(), reason="no CUDA device")
def test_cuda_matches_cpu():
    rng = np.random.default_rng(4)
    probe = rng.uniform(0, 1, (32, 64, 3)) ** 3
    args = [torch.tensor(rng.uniform(0.2, 0.8, (2, 3, 8, 8)), dtype=torch.float32),
            torch.tensor([0, 0, 1.0]).expand(2, 3)[:, :, None, None].expand(2, 3, 8, 8),
            torch.full((2, 3), 0.5), torch.tensor([0.05, 0.5])]
    cpu = render(*args, ProbeBank([probe]), [0, 0])
    cuda = render(*[a.cuda() for a in args], ProbeBank([probe], device="cuda"), [0, 0])
    torch.testing.assert_close(cuda.cpu(), cpu, rtol=1e-4, atol=1e-5)


def test_check_renderer_agrees_with_mitsuba_on_bundled_data(tmp_path, mi):
    """CI's run of check-renderer: every bundled material with every bundled probe, at 32x32,
    the brightest specular albedo in half the cases; at least 40 dB everywhere, and the HDR
    images within 1% relative MSE."""
    from render.torch_renderer.check import compare

    report = compare(BUNDLED_PROBES, BUNDLED_MATERIALS, size=32, spp=1024, roughness=ROUGHNESS,
                     out=tmp_path, progress=False)
    assert report["cases"] == 9
    assert report["worst"]["psnr_db"] >= 40.0, report["worst"]
    assert report["max_relative_mse"] <= 0.01
    assert len(list(tmp_path.glob("*.png"))) == 9 and (tmp_path / "report.json").is_file()


def test_check_renderer_command_fails_over_its_threshold(tmp_path, mi):
    from render.cli.check_renderer import main

    args = ["--probes", str(BUNDLED_PROBES), "--svbrdfs", str(BUNDLED_MATERIALS),
            "--size", "16", "--spp", "64", "--roughness", "0.3"]
    assert CliRunner().invoke(main, args + ["--threshold", "10"]).exit_code == 0
    failed = CliRunner().invoke(main, args + ["--threshold", "200"])
    assert failed.exit_code == 1 and "below 200" in failed.output
    bad = CliRunner().invoke(main, args[:4] + ["--svbrdfs", str(tmp_path / "missing")])
    assert bad.exit_code == 1 and "missing" in bad.output


def test_gradients_agree_with_mitsuba_automatic_differentiation(tmp_path, mi):
    """check-renderer --gradients on the bundled materials and probes at 8x8, views to 60
    degrees: every parameter's gradient within 2% plus 3 times the reference's Monte Carlo
    noise, measured from the spread of 8 passes of 1024 spp (at most about 8% for the maps
    and the specular albedo of these cases, up to 90% for the roughness, whose functional
    cancels over the image: docs/torch-renderer.md). The albedo's gradient, whose reference
    is nearly noise-free, within 1% in every case; a gradient 5% off is flagged."""
    from render.torch_renderer.gradient_check import agreement, compare_gradients

    report = compare_gradients(BUNDLED_PROBES, BUNDLED_MATERIALS, size=8, spp=1024, passes=8,
                               roughness=ROUGHNESS, max_view_angle=60.0, out=tmp_path,
                               progress=False)
    assert report["cases"] == 9 and (tmp_path / "gradients.json").is_file()
    for name, summary in report["summary"].items():
        assert summary["all_agree"], (name, [row[name] for row in report["rows"]])
    assert report["summary"]["albedo"]["worst_error"] < 0.01
    assert report["summary"]["albedo"]["min_cosine"] > 0.9999
    rng = np.random.default_rng(0)
    truth = rng.normal(size=64)
    estimates = [truth + rng.normal(scale=0.001, size=64) for _ in range(4)]
    assert agreement(truth, estimates, 0.02)["agrees"]
    assert not agreement(1.05 * truth, estimates, 0.02)["agrees"]


def test_check_renderer_gradients_command_fails_where_gradients_disagree(tmp_path, mi):
    from render.cli.check_renderer import main

    args = ["--probes", str(BUNDLED_PROBES), "--svbrdfs", str(BUNDLED_MATERIALS), "--size",
            "4", "--spp", "64", "--passes", "2", "--roughness", "0.3", "--gradients"]
    passed = CliRunner().invoke(main, args + ["--tolerance", "10"])
    assert passed.exit_code == 0, passed.output
    assert "normal" in passed.output and "all_agree" in passed.output
    failed = CliRunner().invoke(main, args + ["--tolerance", "-10"])
    assert failed.exit_code == 1 and "gradients disagree" in failed.output
