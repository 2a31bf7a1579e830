"""The tasks of ``render-dataset`` and the renderer of a task, which writes nothing.

Work is split into tasks, one per (material, probe, rotation): a task renders the material
under the probe at a random rotation (and view, if enabled), then cuts ``crops`` random crops,
each turned by a random quarter turn, auto-exposed and clamped. Every random choice comes from
a generator seeded by (seed, material, probe, rotation), so the output does not depend on the
number of workers or on the order in which tasks run.

A TaskRenderer turns tasks into TaskResults in whichever process holds it (the one that started
the run, a pool worker, a Ray worker); ``write_task`` writes a result's files.
"""

import json
import zlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from render.common.atomic_files import write_json, write_npz
from render.common.exposure import expose_numpy
from render.common.labels import relative_labels, rotate_quarter_turns
from render.common.probes import Probe, load_probe
from render.common.views import random_view
from render.dataset.config import DatasetConfig
from render.materials.reduced_svbrdf import ReducedSVBRDF, load_material, resample


@dataclass(frozen=True)
class Task:
    material: Path
    probe: Path
    rotation: int
    split: str

    @property
    def name(self) -> str:
        return f"{self.material.name}__{self.probe.stem}__r{self.rotation:02d}"


def split_names(names: list[str], fraction: float, seed: int, salt: int) -> set[str]:
    """Names held out for testing: a seeded random ``fraction`` (at least one if the fraction
    is positive, never all)."""
    count = min(len(names) - 1, max(1, round(fraction * len(names)))) if fraction > 0 else 0
    order = np.random.default_rng([seed, salt]).permutation(len(names))
    return {names[i] for i in order[:count]}


def plan_tasks(cfg: DatasetConfig, materials: list[Path], probes: list[Path]) -> list[Task]:
    test_materials = split_names([m.name for m in materials], cfg.test_materials, cfg.seed, 1)
    test_probes = split_names([p.stem for p in probes], cfg.test_probes, cfg.seed, 2)
    tasks = []
    for material in materials:
        for probe in probes:
            in_test = (material.name in test_materials, probe.stem in test_probes)
            if in_test[0] != in_test[1]:
                continue
            split = "test" if in_test[0] else "train"
            tasks.extend(Task(material, probe, r, split) for r in range(cfg.rotations))
    return tasks


def task_rng(cfg: DatasetConfig, task: Task) -> np.random.Generator:
    """The generator of every random choice of a task, independent of run order."""
    key = [cfg.seed, zlib.crc32(task.material.name.encode()), zlib.crc32(task.probe.stem.encode()),
           task.rotation]
    return np.random.default_rng(key)


class TaskRenderer:
    """Renders tasks in one process, keeping loaded materials and probes.

    ``inputs``, if given, maps a material folder or probe file to a callable returning the
    resampled material or the loaded probe (Ray workers fetch them from the object store);
    otherwise they are read from disk.
    """

    def __init__(self, cfg: DatasetConfig, threads: int | None = None,
                 inputs: dict[Path, Callable[[], ReducedSVBRDF | Probe]] | None = None):
        from render.mitsuba_reference.scene import PlanarSampleRenderer  # imports Mitsuba

        self.cfg = cfg
        self.renderer = PlanarSampleRenderer(cfg.variant, cfg.spp, cfg.sampler, threads)
        self.inputs = inputs
        self._materials, self._probes = {}, {}

    def _material(self, folder):
        if folder not in self._materials:
            self._materials[folder] = (self.inputs[folder]() if self.inputs else
                                       resample(load_material(folder), self.cfg.render_size))
        return self._materials[folder]

    def _probe(self, path):
        if path not in self._probes:
            self._probes[path] = self.inputs[path]() if self.inputs else load_probe(path)
        return self._probes[path]

    def render(self, task: Task) -> "TaskResult":
        """Render ``task``; returns its TaskResult (nothing is written)."""
        cfg = self.cfg
        svbrdf, probe = self._material(task.material), self._probe(task.probe)
        rng = task_rng(cfg, task)
        rotation_deg = float(rng.uniform(0, 360))
        view = random_view(rng, cfg.max_view_angle)
        height, width = svbrdf.albedo.shape[:2]
        crops = [(int(rng.integers(0, height - cfg.resolution + 1)),
                  int(rng.integers(0, width - cfg.resolution + 1)), int(rng.integers(4)))
                 for _ in range(cfg.crops)]
        render_seed = int(rng.integers(1 << 31))
        hdr = self.renderer.render(svbrdf, probe, rotation_deg, view, render_seed)

        records, arrays = [], []
        for index, (top, left, turns) in enumerate(crops):
            window = np.s_[top:top + cfg.resolution, left:left + cfg.resolution]
            image, albedo, normal = rotate_quarter_turns(
                hdr[window], svbrdf.albedo[window], svbrdf.normal[window], turns)
            exposed, exposure = expose_numpy(image, cfg.exposure_key)
            albedo_rel, log_specular = relative_labels(albedo, svbrdf.specular)
            record = {
                "id": f"{task.name}_c{index:02d}", "split": task.split,
                "material": task.material.name, "probe": task.probe.stem,
                "material_class": svbrdf.material_class, "material_sources": svbrdf.sources,
                "probe_white_balance": probe.white_balance.tolist(),
                "rotation_index": task.rotation, "rotation_deg": rotation_deg,
                "view": view.tolist(), "crop": {"top": top, "left": left,
                                                "size": cfg.resolution, "quarter_turns": turns},
                "exposure": exposure, "render_seed": render_seed, "spp": cfg.spp,
                "sampler": cfg.sampler, "variant": cfg.variant,
            }
            record["file"] = f"samples/{record['id']}.npz"
            records.append(record)
            arrays.append({"image": exposed.astype(np.float16),
                           "albedo": albedo_rel.astype(np.float16),
                           "normal": normal.astype(np.float16),
                           "log_specular": log_specular.astype(np.float32),
                           "log_roughness": np.array([np.log(svbrdf.roughness)], np.float32),
                           "provenance": np.array(json.dumps(record))})
        return TaskResult(task.name, records, arrays)


@dataclass(frozen=True)
class TaskResult:
    """What one task rendered, ready to be written by ``write_task`` (in whichever process
    started the run, so that workers need no access to the output folder)."""
    name: str
    records: list
    """The samples' provenance records, in crop order."""
    arrays: list
    """Per sample, the arrays of its .npz file."""


def write_task(out: str | Path, result: TaskResult) -> int:
    """Write a task's samples, then its marker (so a marker means the task is complete);
    returns the number of samples."""
    for record, arrays in zip(result.records, result.arrays):
        write_npz(Path(out) / record["file"], **arrays)
    write_json(Path(out) / "tasks" / f"{result.name}.json",
               {"task": result.name, "samples": result.records})
    return len(result.records)
