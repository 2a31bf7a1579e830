"""The paper's reduced SVBRDF (its Equation 1) as a Mitsuba 3 BSDF plugin, ``sa_ward``.

    f_r(wi, wo, x) = rho_d(x) / pi
                   + rho_s * exp(-tan^2(delta) / alpha^2) / (4 pi alpha^2 sqrt(cos_i cos_o))

with a per-pixel diffuse albedo ``rho_d(x)`` (texture ``albedo``, linear RGB), a per-pixel
shading normal (texture ``normal``, tangent-space unit vector stored as raw floats in [-1, 1],
see docs/conventions.md), and a homogeneous specular albedo ``rho_s`` (linear RGB) and Ward
roughness ``alpha``. ``delta`` is the angle between the half vector and the shading normal;
``cos_i``, ``cos_o`` are the cosines of the two directions with the shading normal.

Light only arrives from above the sample plane: directions below the geometric horizon are
cut off even where the shading normal would see them (the plane occludes them).

Sampling mixes cosine-weighted hemisphere sampling (diffuse lobe) with Walter's exact
importance sampling of the Ward half-vector distribution, p(h) = exp(-tan^2 d / a^2) /
(pi a^2 cos^3 d), chosen with probability proportional to the lobes' mean albedos.

Derivatives (``check-renderer --gradients`` takes them with Mitsuba's AD): the four inputs are
differentiable parameters. Sampled directions and pdfs are detached from them, so a sample's
derivative is that of the integrand at a fixed direction over a constant pdf; the
integrator's MIS weights of the BSDF and probe samples sum to one whatever the parameters, so
the estimate of the derivative is unbiased (no boundary terms: the plane is fixed and the
integrand vanishes where a cosine cut moves with the normal).

Import this module only after a Mitsuba variant is set (``render.mitsuba_reference.loading``).
"""

from __future__ import annotations

from collections.abc import Sequence

import drjit as dr
import mitsuba as mi

PLUGIN_NAME = "sa_ward"


class WardSVBRDF(mi.BSDF):
    """Per-pixel diffuse albedo and normal, homogeneous Ward specular lobe."""

    def __init__(self, props: mi.Properties):
        mi.BSDF.__init__(self, props)
        self.albedo = props.get_texture("albedo")
        self.normal = props.get_unbounded_texture("normal")
        self.specular = mi.Color3f(props["specular"])
        self.alpha = mi.Float(props["alpha"])
        dr.make_opaque(self.specular, self.alpha)  # new values reuse the compiled kernel
        diffuse = (mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide
                   | mi.BSDFFlags.SpatiallyVarying)
        glossy = mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.FrontSide
        self.m_components = [diffuse, glossy]
        self.m_flags = diffuse | glossy

    def _shading_frame(self, si, active):
        """Frame of the mapped normal, expressed in the surface's local (tangent) frame."""
        n = self.normal.eval(si, active)
        n = dr.normalize(mi.Vector3f(n[0], n[1], n[2]))
        s = dr.normalize(mi.Vector3f(1, 0, 0) - n * n.x)
        return mi.Frame3f(s, dr.cross(n, s), n)

    def _spec_probability(self, albedo):
        spec = dr.mean(self.specular)
        diff = dr.mean(albedo)
        return dr.select(spec + diff > 0, spec / (spec + diff), 0.0)

    def _eval_pdf_local(self, albedo, wi, wo, wo_geom_z, wi_geom_z, p_spec):
        """BRDF * cos and mixture pdf (detached) for directions in the shading frame."""
        cos_i, cos_o = wi.z, wo.z
        valid = (cos_i > 0) & (cos_o > 0) & (wo_geom_z > 0) & (wi_geom_z > 0)
        h = dr.normalize(wi + wo)
        cos_d2 = dr.square(h.z)
        tan_d2 = (1 - cos_d2) / cos_d2
        a2 = dr.square(self.alpha)
        lobe = dr.exp(-tan_d2 / a2) / (4 * dr.pi * a2)
        spec = self.specular * lobe * dr.safe_sqrt(cos_o / cos_i)
        value = (albedo * dr.inv_pi * cos_o + spec) & valid
        pdf_h = dr.exp(-tan_d2 / a2) / (dr.pi * a2 * cos_d2 * h.z)
        pdf_spec = pdf_h / (4 * dr.abs(dr.dot(wo, h)))
        pdf_diff = cos_o * dr.inv_pi
        pdf = dr.select(valid, p_spec * pdf_spec + (1 - p_spec) * pdf_diff, 0.0)
        return value, dr.detach(pdf)

    def _evaluate(self, si, wo, active):
        frame = self._shading_frame(si, active)
        albedo = self.albedo.eval(si, active)
        return self._eval_pdf_local(albedo, frame.to_local(si.wi), frame.to_local(wo),
                                    wo.z, si.wi.z, self._spec_probability(albedo))

    def eval(self, ctx: mi.BSDFContext, si: mi.SurfaceInteraction3f, wo: mi.Vector3f,
             active: bool | mi.Bool = True) -> mi.Color3f:
        return self._evaluate(si, wo, active)[0]

    def pdf(self, ctx: mi.BSDFContext, si: mi.SurfaceInteraction3f, wo: mi.Vector3f,
            active: bool | mi.Bool = True) -> mi.Float:
        return self._evaluate(si, wo, active)[1]

    def eval_pdf(self, ctx: mi.BSDFContext, si: mi.SurfaceInteraction3f, wo: mi.Vector3f,
                 active: bool | mi.Bool = True) -> tuple[mi.Color3f, mi.Float]:
        return self._evaluate(si, wo, active)

    def sample(self, ctx: mi.BSDFContext, si: mi.SurfaceInteraction3f, sample1: mi.Float,
               sample2: mi.Point2f,
               active: bool | mi.Bool = True) -> tuple[mi.BSDFSample3f, mi.Color3f]:
        frame = self._shading_frame(si, active)
        albedo = self.albedo.eval(si, active)
        fixed = _detached_frame(frame)  # the sampled direction does not move with parameters
        p_spec = self._spec_probability(albedo)
        wi = fixed.to_local(si.wi)

        choose_spec = sample1 < p_spec
        tan_d2 = -dr.square(dr.detach(self.alpha)) * dr.log(1 - sample2.x)
        cos_d = dr.rsqrt(1 + tan_d2)
        sin_d = dr.safe_sqrt(1 - dr.square(cos_d))
        sin_p, cos_p = dr.sincos(2 * dr.pi * sample2.y)
        h = mi.Vector3f(sin_d * cos_p, sin_d * sin_p, cos_d)
        wo_spec = 2 * dr.dot(wi, h) * h - wi
        wo_diff = mi.warp.square_to_cosine_hemisphere(sample2)
        wo_local = dr.select(choose_spec, wo_spec, wo_diff)
        wo = fixed.to_world(wo_local)

        value, pdf = self._eval_pdf_local(albedo, frame.to_local(si.wi), frame.to_local(wo),
                                          wo.z, si.wi.z, p_spec)
        bs = dr.zeros(mi.BSDFSample3f)
        bs.wo = wo
        bs.pdf = pdf
        bs.eta = 1.0
        bs.sampled_component = dr.select(choose_spec, mi.UInt32(1), mi.UInt32(0))
        bs.sampled_type = dr.select(choose_spec, mi.UInt32(+mi.BSDFFlags.GlossyReflection),
                                    mi.UInt32(+mi.BSDFFlags.DiffuseReflection))
        weight = dr.select(pdf > 0, value / pdf, 0.0)
        return bs, weight & active

    def traverse(self, callback: mi.TraversalCallback) -> None:
        callback.put("specular", self.specular, mi.ParamFlags.Differentiable)
        callback.put("alpha", self.alpha, mi.ParamFlags.Differentiable)
        callback.put("albedo", self.albedo, mi.ParamFlags.Differentiable)
        callback.put("normal", self.normal, mi.ParamFlags.Differentiable)

    def parameters_changed(self, keys: Sequence[str]) -> None:
        dr.make_opaque(self.specular, self.alpha)

    def to_string(self) -> str:
        return f"WardSVBRDF[specular={self.specular}, alpha={self.alpha}]"


def _detached_frame(frame: mi.Frame3f) -> mi.Frame3f:
    return mi.Frame3f(dr.detach(frame.s), dr.detach(frame.t), dr.detach(frame.n))


def register() -> None:
    """Make ``<bsdf type="sa_ward">`` available to Mitsuba's loaders."""
    mi.register_bsdf(PLUGIN_NAME, lambda props: WardSVBRDF(props))
