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
3. the paper's relative labels of the crop (render.common.labels.relative_labels); with
   ``mix_specular``, the homogeneous specular albedo and roughness come from another random
   material of the folder (its own one time in N), so that they are not a function of the
   texture (below);
4. a render under a random probe of ``probe_choices``, at a random rotation about +z and a view
   within ``max_view_angle`` of the normal, auto-exposed and clamped to [0, 1].

Why ``mix_specular``: a material has one specular albedo and one roughness, so N materials give
the network only N specular pairs, each tied to one texture. The plastic network shipped until
2026-12-01 (400 procedural sets) learned that tie: its log roughness correlates with the truth
at +0.48 on 80 crops of its training sets and at -0.34 on 80 of unseen ones (make-materials
seed 9; both under the training probes), where a constant would do better. Mixed, every texture
is seen with every pair of the folder, and the pair has to be read from the reflection. It
also hides real ties: on procedural wood, whose finish sets both roughness and relief, mixing
made the network worse (models/README.md).

Rendering the relative albedos directly is exact: the exposure cancels any common scale. Every
choice comes from the numpy generator given, so a minibatch is a function of that generator's
seed.

Memory: the resampled maps are held as float16 (relative rounding error at most 2^-11, about
0.05%), half of float32's: 1,200 materials of 512 px take about 3.8 GB rather than
7.5 GB, so a training run on the project's 24 GB CPU machine can hold twice the materials.
Crops are cut from them and converted to float32 (normals renormalized) before anything is
computed.
"""

import dataclasses
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import torch

from render.common.exposure import expose
from render.common.labels import relative_labels, rotate_quarter_turns
from render.common.views import random_view
from render.materials.reduced_svbrdf import find_materials, load_material, resample
from render.torch_renderer.renderer import ProbeBank, render


class MapSampler:
    """Random labeled samples of the materials in ``folder`` (one sub-folder per material)."""

    def __init__(self, folder: str | Path, probes: ProbeBank,
                 probe_choices: Sequence[int] | np.ndarray, size: int, render_size: int,
                 max_view_angle: float = 0.0, crop_scales: Sequence[int] = (1,),
                 mix_specular: bool = False):
        if not crop_scales or any(int(k) != k or k < 1 for k in crop_scales):
            raise ValueError(f"crop scales {list(crop_scales)} are not whole numbers >= 1")
        if render_size < size * max(crop_scales):
            raise ValueError(f"render_size {render_size} is smaller than the largest crop "
                             f"({size} x {max(crop_scales)})")
        self.folder, self.probes = folder, probes
        self.probe_choices = np.asarray(probe_choices)
        self.size, self.max_view_angle = size, max_view_angle
        self.crop_scales = [int(k) for k in crop_scales]
        self.mix_specular = mix_specular
        self.materials = [_half_precision(resample(load_material(path), render_size))
                          for path in find_materials(folder)]

    def log_specular_range(self) -> tuple[float, float]:
        """(lowest, highest) log relative specular albedo over the materials, each taken
        relative to its whole map (a crop's scale differs a little); with ``mix_specular``,
        over every pairing of one material's specular albedo with another's albedo."""
        log_specular = np.log([np.asarray(m.specular, np.float64) for m in self.materials])
        log_scale = np.log([2.0 * np.mean(m.albedo, dtype=np.float64) for m in self.materials])
        # pairings[i, c, j]: channel c of material i's specular albedo relative to material j's
        pairings = np.subtract.outer(log_specular, log_scale)
        values = pairings if self.mix_specular else np.diagonal(pairings, axis1=0, axis2=2)
        return float(values.min()), float(values.max())

    def batch(self, rng: np.random.Generator, count: int,
              shard: Callable[[list[int]], list[int]] = list
              ) -> dict[str, torch.Tensor | list[dict]]:
        """A dict of float32 tensors on the probes' device: image, albedo, normal
        (n, 3, size, size); log_specular (n, 3); log_roughness (n, 1); and ``provenance``,
        a list of dicts (material, specular_from (the material whose specular albedo and
        roughness the sample has), probe_index, rotation_deg).

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
        provenance = [{"material": crop["material"], "specular_from": crop["specular_from"],
                       "probe_index": int(p), "rotation_deg": float(r)}
                      for crop, p, r in zip(crops, probe_index, rotation)]
        return {"image": expose(hdr)} | labels | {"provenance": provenance}

    def _choice(self, rng):
        """(material index, crop top, crop left, quarter turns, crop scale, index of the
        material giving the specular albedo and roughness), drawn from ``rng`` (the scale only
        when there is more than one to choose from, the specular material only with
        ``mix_specular``)."""
        index = int(rng.integers(len(self.materials)))
        height, width = self.materials[index].albedo.shape[:2]
        scale = self.crop_scales[0]
        if len(self.crop_scales) > 1:
            scale = self.crop_scales[int(rng.integers(len(self.crop_scales)))]
        window = self.size * scale
        top = int(rng.integers(0, height - window + 1))
        left = int(rng.integers(0, width - window + 1))
        turns = int(rng.integers(4))
        specular_index = int(rng.integers(len(self.materials))) if self.mix_specular else index
        return index, top, left, turns, scale, specular_index

    def _crop(self, index, top, left, turns, scale, specular_index):
        """Channel-first labels of one crop."""
        material, specular_material = self.materials[index], self.materials[specular_index]
        side = self.size * scale
        window = np.s_[top:top + side, left:left + side]
        albedo = material.albedo[window].astype(np.float32)
        normal = material.normal[window].astype(np.float32)
        if scale > 1:
            albedo, normal = _box_down(albedo, scale), _box_down(normal, scale)
        normal /= np.linalg.norm(normal, axis=2, keepdims=True)
        _, albedo, normal = rotate_quarter_turns(albedo, albedo, normal, turns)
        albedo, log_specular = relative_labels(albedo, specular_material.specular)
        return {"material": material.name, "specular_from": specular_material.name,
                "albedo": albedo.transpose(2, 0, 1), "normal": normal.transpose(2, 0, 1),
                "log_specular": log_specular.astype(np.float32),
                "log_roughness": np.array([np.log(specular_material.roughness)], np.float32)}


def _half_precision(material):
    """``material`` with its albedo and normal maps as float16 (module docstring, memory)."""
    return dataclasses.replace(material, albedo=material.albedo.astype(np.float16),
                               normal=material.normal.astype(np.float16))


def _box_down(pixels, factor):
    """(H, W, C) pixels averaged over ``factor`` x ``factor`` blocks (H, W divisible by it)."""
    height, width, channels = pixels.shape
    return pixels.reshape(height // factor, factor, width // factor, factor, channels).mean(
        (1, 3), dtype=np.float64).astype(np.float32)
