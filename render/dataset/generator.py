"""``render-dataset``: labeled (photo, reduced SVBRDF) pairs rendered with Mitsuba 3.

The work is split into tasks (render/dataset/tasks.py), rendered in this process, in a pool of
worker processes or as Ray tasks (render/dataset/ray_runner.py), and written by this process as
they come back; re-running an interrupted run renders only the tasks it had not finished.

Output folder (docs/dataset-format.md):
    config.json             the resolved configuration
    samples/<id>.npz        image, albedo, normal, log_specular, log_roughness, provenance
    tasks/<task>.json       written last by each task: its samples' provenance (resume marker)
    index.json              every sample with its split and provenance, written at the end
    contact_sheet.png       a few samples for people to look at
"""

import dataclasses
import json
import logging
import multiprocessing
import os
from collections.abc import Iterator
from pathlib import Path

import numpy as np
from tqdm import tqdm

from render.common.atomic_files import write_json
from render.common.probes import find_probes, load_probe
from render.common.resume import continue_folder
from render.dataset.config import DatasetConfig
from render.dataset.contact_sheet import write_contact_sheet
from render.dataset.tasks import Task, TaskRenderer, TaskResult, plan_tasks, write_task
from render.materials.reduced_svbrdf import find_materials, load_material

log = logging.getLogger(__name__)
CONTACT_SHEET_ROWS = 12
MAY_CHANGE = ("workers", "out", "ray", "ray_chunk", "ray_cpus_per_task")
"""Options that do not change the samples: a resumed run may use other values
(render.common.resume)."""


def validate_inputs(cfg: DatasetConfig) -> tuple[list[Path], list[Path]]:
    """Load every material and probe once, so bad input fails before any rendering."""
    materials, probes = find_materials(cfg.svbrdfs), find_probes(cfg.probes)
    for folder in materials:
        load_material(folder)
    for path in probes:
        load_probe(path)
    return materials, probes


_worker = None


def _init_worker(cfg, threads):
    global _worker
    _worker = TaskRenderer(cfg, threads)


def _render_in_worker(task):
    return _worker.render(task)


def run(cfg: DatasetConfig) -> dict:
    """Render the dataset described by ``cfg`` (resuming if ``cfg.out`` holds a partial run)."""
    cfg.validate()
    out = Path(cfg.out)
    materials, probes = validate_inputs(cfg)
    continue_folder(out, dataclasses.asdict(cfg), MAY_CHANGE, "render-dataset")
    for stale in [*out.glob("samples/.*.tmp*"), *out.glob("tasks/.*.tmp*")]:
        stale.unlink()  # temporary files of a killed run; their task is redone below

    tasks = plan_tasks(cfg, materials, probes)
    pending = [t for t in tasks if not (out / "tasks" / f"{t.name}.json").exists()]
    log.info("%d tasks (%d samples), %d already done", len(tasks), len(tasks) * cfg.crops,
             len(tasks) - len(pending))
    with tqdm(total=len(tasks) * cfg.crops, initial=(len(tasks) - len(pending)) * cfg.crops,
              unit="sample", desc="render-dataset") as progress:
        for result in render_tasks(cfg, pending):
            progress.update(write_task(out, result))
    return finish(cfg, tasks)


def render_tasks(cfg: DatasetConfig, tasks: list[Task]) -> Iterator[TaskResult]:
    """Yield the TaskResult of every task, in any order: in this process (one worker), in a
    pool of ``workers`` local processes, or as Ray tasks when ``cfg.ray`` is set."""
    if cfg.ray is not None:
        from render.dataset.ray_runner import render_on_ray  # imports Ray

        yield from render_on_ray(cfg, tasks)
    elif cfg.workers == 1:
        renderer = TaskRenderer(cfg)
        yield from map(renderer.render, tasks)
    else:
        threads = max(1, (os.cpu_count() or 1) // cfg.workers)
        context = multiprocessing.get_context("spawn")
        with context.Pool(cfg.workers, _init_worker, (cfg, threads)) as pool:
            yield from pool.imap_unordered(_render_in_worker, tasks)


def finish(cfg: DatasetConfig, tasks: list[Task]) -> dict:
    """Write index.json and the contact sheet from the task markers; returns the index."""
    out = Path(cfg.out)
    samples = []
    for task in tasks:
        samples.extend(json.loads((out / "tasks" / f"{task.name}.json").read_text())["samples"])
    samples.sort(key=lambda s: s["id"])
    index = {"config": dataclasses.asdict(cfg), "count": len(samples),
             "splits": {s: sum(r["split"] == s for r in samples) for s in ("train", "test")},
             "samples": samples}
    write_json(out / "index.json", index)
    picks = np.linspace(0, len(samples) - 1, min(CONTACT_SHEET_ROWS, len(samples))).astype(int)
    shown = []
    for i in sorted(set(picks.tolist())):
        with np.load(out / samples[i]["file"]) as data:
            shown.append({k: data[k].astype(np.float32) for k in
                          ("image", "albedo", "normal", "log_specular", "log_roughness")}
                         | {"provenance": samples[i]})
    write_contact_sheet(out / "contact_sheet.png", shown)
    return index
