"""Labeled samples rendered on the fly from material maps by the torch renderer.

The alternative to a ``render-dataset`` folder (``sa-train --labeled-maps``): a sample is made
as render-dataset makes one, with the torch renderer (checked against Mitsuba,
docs/torch-renderer.md) in place of Mitsuba, so every minibatch sees new lighting:

1. a random material of the folder, its maps resampled so that their shorter side is
   ``render_size`` (as render-dataset's ``--render-size``);
2. a random square crop of ``size`` x k pixels, k drawn from ``crop_scales`` (1 by default),
   box filtered down to ``size`` x ``size`` (normals renormalized) and turned by a random
   quarter turn (normals turn with it): k = 2 shows the texture at half its scale, as a
   photo taken from twice as far;
3. the paper's relative labels of the crop (render.common.labels.relative_labels);
4. a render under a random probe of ``probe_choices``, at a random rotation about +z and a view
   within ``max_view_angle`` of the normal, auto-exposed and clamped to [0, 1].

Rendering the relative albedos directly is exact: the exposure cancels any common scale. Every
choice comes from the numpy generator given, so a minibatch is a function of that generator's
seed.
"""

import numpy as np
import torch

from render.common.exposure import expose
from render.common.labels import relative_labels, rotate_quarter_turns
from render.common.views import random_view
from render.materials.reduced_svbrdf import find_materials, load_material, resample
from render.torch_renderer.renderer import render


class MapSampler:
    """Random labeled samples of the materials in ``folder`` (one sub-folder per material)."""

    def __init__(self, folder, probes, probe_choices, size, render_size, max_view_angle=0.0,
                 crop_scales=(1,)):
        if not crop_scales or any(int(k) != k or k < 1 for k in crop_scales):
            raise ValueError(f"crop scales {list(crop_scales)} are not whole numbers >= 1")
        if render_size < size * max(crop_scales):
            raise ValueError(f"render_size {render_size} is smaller than the largest crop "
                             f"({size} x {max(crop_scales)})")
        self.folder, self.probes = folder, probes
        self.probe_choices = np.asarray(probe_choices)
        self.size, self.max_view_angle = size, max_view_angle
        self.crop_scales = [int(k) for k in crop_scales]
        self.materials = [resample(load_material(path), render_size)
                          for path in find_materials(folder)]

    def log_specular_range(self):
        """(lowest, highest) log relative specular albedo over the materials, each taken
        relative to its whole map (a crop's scale differs a little)."""
        values = np.concatenate([relative_labels(m.albedo, m.specular)[1]
                                 for m in self.materials])
        return float(values.min()), float(values.max())

    def batch(self, rng, count, shard=list):
        """A dict of float32 tensors on the probes' device: image, albedo, normal
        (n, 3, size, size); log_specular (n, 3); log_roughness (n, 1); and ``provenance``,
        a list of dicts (material, probe_index, rotation_deg).

        All ``count`` samples are drawn from ``rng``; ``shard`` picks the ones this process
        renders (n of them; under torchrun, its contiguous shard of the global minibatch)."""
        choices = [self._choice(rng) for _ in range(count)]
        probe_index = self.probe_choices[rng.integers(len(self.probe_choices), size=count)]
        rotation = rng.uniform(0.0, 360.0, size=count)
        view = np.stack([random_view(rng, self.max_view_angle) for _ in range(count)])
        kept = shard(list(range(count)))
        choices = [choices[i] for i in kept]
        probe_index, rotation, view = probe_index[kept], rotation[kept], view[kept]
        crops = [self._crop(*choice) for choice in choices]
        labels = {name: torch.as_tensor(np.stack([crop[name] for crop in crops]),
                                        dtype=torch.float32, device=self.probes.device)
                  for name in ("albedo", "normal", "log_specular", "log_roughness")}
        hdr = render(labels["albedo"], labels["normal"], torch.exp(labels["log_specular"]),
                     torch.exp(labels["log_roughness"][:, 0]), self.probes, probe_index,
                     rotation, view)
        provenance = [{"material": crop["material"], "probe_index": int(p),
                       "rotation_deg": float(r)} for crop, p, r in zip(crops, probe_index, rotation)]
        return {"image": expose(hdr)} | labels | {"provenance": provenance}

    def _choice(self, rng):
        """(material index, crop top, crop left, quarter turns, crop scale), drawn from
        ``rng`` (the scale only when there is more than one to choose from)."""
        index = int(rng.integers(len(self.materials)))
        height, width = self.materials[index].albedo.shape[:2]
        scale = self.crop_scales[0]
        if len(self.crop_scales) > 1:
            scale = self.crop_scales[int(rng.integers(len(self.crop_scales)))]
        window = self.size * scale
        return (index, int(rng.integers(0, height - window + 1)),
                int(rng.integers(0, width - window + 1)), int(rng.integers(4)), scale)

    def _crop(self, index, top, left, turns, scale):
        """Channel-first labels of one crop."""
        material = self.materials[index]
        side = self.size * scale
        window = np.s_[top:top + side, left:left + side]
        albedo, normal = material.albedo[window], material.normal[window]
        if scale > 1:
            albedo, normal = _box_down(albedo, scale), _box_down(normal, scale)
            normal /= np.linalg.norm(normal, axis=2, keepdims=True)
        _, albedo, normal = rotate_quarter_turns(albedo, albedo, normal, turns)
        albedo, log_specular = relative_labels(albedo, material.specular)
        return {"material": material.name,
                "albedo": albedo.transpose(2, 0, 1), "normal": normal.transpose(2, 0, 1),
                "log_specular": log_specular.astype(np.float32),
                "log_roughness": np.array([np.log(material.roughness)], np.float32)}


def _box_down(pixels, factor):
    """(H, W, C) pixels averaged over ``factor`` x ``factor`` blocks (H, W divisible by it)."""
    height, width, channels = pixels.shape
    return pixels.reshape(height // factor, factor, width // factor, factor, channels).mean(
        (1, 3), dtype=np.float64).astype(np.float32)
