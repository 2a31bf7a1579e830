"""``render-dataset --ray``: the dataset's tasks rendered as Ray tasks on a cluster.

The tasks (material, probe, rotation) are grouped into chunks of ``cfg.ray_chunk``; each chunk
is one Ray task reserving ``cfg.ray_cpus_per_task`` CPUs, and Mitsuba renders it with that many
threads. A Ray worker process builds one TaskRenderer per configuration and keeps it, so it
loads Mitsuba (and compiles its kernels) once, whatever the number of chunks it renders.

Inputs and outputs travel through Ray's object store, so the nodes need the project installed
but no shared file system: this process loads every material (resampled to the render size)
and probe once and puts it in the store; a worker fetches only those its chunks use. The
rendered arrays come back here and are written by ``render.dataset.tasks.write_task`` exactly
as in a local run. Since every random choice of a task comes from (seed, task), the files are
byte-identical to a local run's, and resuming works the same way.

Ray is imported only here, so render-dataset without ``--ray`` never needs it.
"""

import logging
from collections.abc import Iterator

import ray

from render.common.probes import load_probe
from render.dataset.config import DatasetConfig
from render.dataset.tasks import Task, TaskRenderer, TaskResult
from render.materials.reduced_svbrdf import load_material, resample

log = logging.getLogger(__name__)

_renderers = {}
"""Per Ray worker process: the TaskRenderer of each configuration it has rendered for."""


def _render_chunk(cfg, tasks, input_refs):
    """Ray task: the TaskResults of ``tasks``; ``input_refs`` maps each material folder and
    probe file to the ObjectRef of its loaded form."""
    if cfg not in _renderers:
        inputs = {path: (lambda ref=ref: ray.get(ref)) for path, ref in input_refs.items()}
        _renderers[cfg] = TaskRenderer(cfg, threads=cfg.ray_cpus_per_task, inputs=inputs)
    return [_renderers[cfg].render(task) for task in tasks]


def connect(cfg: DatasetConfig) -> None:
    """Join the cluster at ``cfg.ray``, or start a Ray instance here for ``local``."""
    if ray.is_initialized():
        return
    options = {"include_dashboard": False, "logging_level": logging.WARNING}
    if cfg.ray == "local":
        ray.init(num_cpus=cfg.workers, **options)
    else:
        ray.init(address=cfg.ray, **options)
    log.info("Ray cluster: %s CPUs", ray.cluster_resources().get("CPU", 0))


def render_on_ray(cfg: DatasetConfig, tasks: list[Task]) -> Iterator[TaskResult]:
    """Yield the TaskResult of every task in ``tasks``, in completion order."""
    if not tasks:
        return
    connect(cfg)
    input_refs = {}
    for task in tasks:
        if task.material not in input_refs:
            input_refs[task.material] = ray.put(resample(load_material(task.material),
                                                         cfg.render_size))
        if task.probe not in input_refs:
            input_refs[task.probe] = ray.put(load_probe(task.probe))
    remote = ray.remote(num_cpus=cfg.ray_cpus_per_task)(_render_chunk)
    pending = [remote.remote(cfg, tasks[start:start + cfg.ray_chunk], input_refs)
               for start in range(0, len(tasks), cfg.ray_chunk)]
    log.info("%d Ray tasks of up to %d render tasks", len(pending), cfg.ray_chunk)
    while pending:
        done, pending = ray.wait(pending, num_returns=1)
        yield from ray.get(done[0])
