"""The sa_ward plugin: its sampler matches its pdf (chi-square, as Mitsuba's own BSDF tests)."""

import numpy as np
import pytest


def _unit(v):
    v = np.asarray(v, float)
    return (v / np.linalg.norm(v)).tolist()


@pytest.mark.parametrize("alpha, normal, wi", [
    (0.02, [0, 0, 1], [0.3, 0.2, 0.93]),
    (0.05, [0.3, -0.2, 0.93], [0.5, 0, 0.866]),
    (0.3, [0, 0, 1], [-0.6, 0.3, 0.74]),
    (1.0, [0.5, 0.2, 0.84], [-0.7, 0.1, 0.7]),
])
def test_sampler_matches_pdf(mi, alpha, normal, wi):
    from mitsuba.chi2 import BSDFAdapter, ChiSquareTest, SphericalDomain

    bsdf = {"type": "sa_ward", "albedo": {"type": "rgb", "value": [0.3, 0.4, 0.5]},
            "normal": {"type": "rgb", "value": _unit(normal)},
            "specular": mi.ScalarColor3f(0.2, 0.3, 0.4), "alpha": alpha}
    sample_func, pdf_func = BSDFAdapter("sa_ward", bsdf, wi=_unit(wi))
    # The fine integration grid (ires) resolves the narrow lobe at alpha = 0.02 within a cell.
    test = ChiSquareTest(domain=SphericalDomain(), sample_func=sample_func, pdf_func=pdf_func,
                         sample_dim=3, ires=16)
    assert test.run(), test.messages


def test_eval_matches_equation_1(mi):
    """eval() = (rho_d / pi + rho_s exp(-tan^2 d / a^2) / (4 pi a^2 sqrt(cos_i cos_o))) cos_o."""
    import drjit as dr

    alpha, rho_d, rho_s = 0.2, np.array([0.3, 0.4, 0.5]), np.array([0.2, 0.3, 0.4])
    bsdf = mi.load_dict({"type": "sa_ward", "albedo": {"type": "rgb", "value": rho_d.tolist()},
                         "normal": {"type": "rgb", "value": [0, 0, 1]},
                         "specular": mi.ScalarColor3f(*rho_s), "alpha": alpha})
    wi, wo = np.array(_unit([0.4, 0.1, 0.9])), np.array(_unit([-0.3, 0.05, 0.95]))
    si = dr.zeros(mi.SurfaceInteraction3f)
    si.wi = mi.Vector3f(*wi.tolist())
    value = np.array(bsdf.eval(mi.BSDFContext(), si, mi.Vector3f(*wo.tolist()))).ravel()
    h = (wi + wo) / np.linalg.norm(wi + wo)
    tan2 = (1 - h[2] ** 2) / h[2] ** 2
    expected = (rho_d / np.pi + rho_s * np.exp(-tan2 / alpha ** 2)
                / (4 * np.pi * alpha ** 2 * np.sqrt(wi[2] * wo[2]))) * wo[2]
    np.testing.assert_allclose(value, expected, rtol=1e-5)


def test_light_below_the_plane_is_cut_off(mi):
    """A tilted shading normal may face below the horizon; the plane still blocks that light."""
    import drjit as dr

    bsdf = mi.load_dict({"type": "sa_ward", "albedo": {"type": "rgb", "value": 0.5},
                         "normal": {"type": "rgb", "value": _unit([0.8, 0, 0.6])},
                         "specular": mi.ScalarColor3f(0.1), "alpha": 0.3})
    si = dr.zeros(mi.SurfaceInteraction3f)
    si.wi = mi.Vector3f(0, 0, 1)
    below = mi.Vector3f(*_unit([1, 0, -0.1]))  # faces the shading normal, under the plane
    ctx = mi.BSDFContext()
    assert np.all(np.array(bsdf.eval(ctx, si, below)) == 0)
    assert np.all(np.array(bsdf.pdf(ctx, si, below)) == 0)
