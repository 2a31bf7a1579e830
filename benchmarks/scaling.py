"""Benchmark of scale-out: render-dataset with 1 and 2 workers (local processes and Ray) and
sa-train with 1 and 2 processes (torchrun, gloo on the CPU), with the scaling efficiency
(throughput with 2 / (2 x throughput with 1)). Prints JSON.

Mitsuba renders with at least 2 threads per worker and torch uses every core in one process
(torchrun gives each of several processes one thread), so on a 2-core machine one worker
already uses both cores: there the numbers measure the overhead of each scale-out path, and
scaling itself shows only on machines with more cores than one worker uses.

    python benchmarks/scaling.py [--spp 256] [--render-size 256] [--rotations 4] [--steps 60]

Rendering: the bundled materials and probes, every (material, probe) pair in the train split,
``rotations`` renders each; seconds include starting the worker processes and loading Mitsuba
in them, not starting the local Ray instance (reported on its own). Training: the small
network on 64 px samples of that dataset, global minibatch 16; steps per second from the
trainer's own ms per step (training steps only), after the first logged interval (warm-up).
"""

import dataclasses
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import click

from render.dataset.config import DatasetConfig
from render.dataset.generator import run
from train.networks.checkpoints import checkpoint_files, load_checkpoint

REPO = Path(__file__).resolve().parent.parent


def render_seconds(cfg):
    start = time.perf_counter()
    index = run(cfg)
    return time.perf_counter() - start, index["count"]


def ray_start_seconds(cpus):
    import ray

    start = time.perf_counter()
    ray.init(num_cpus=cpus, include_dashboard=False, logging_level="WARNING")
    return time.perf_counter() - start


def training_steps_per_second(dataset, out, processes, steps_per_log):
    launcher = ([sys.executable, "-m", "torch.distributed.run", "--nproc_per_node",
                 str(processes), "-m", "train.cli.sa_train"] if processes > 1
                else [sys.executable, "-m", "train.cli.sa_train"])
    command = [*launcher, "--dataset", str(dataset), "--out", str(out), "--probes",
               str(REPO / "probes"), "--network", "small", "--batch-size", "16",
               "--labeled-epochs", "1", "--self-augmented-epochs", "0",
               "--log-every", str(steps_per_log)]
    subprocess.run(command, cwd=REPO, check=True, capture_output=True)
    newest = checkpoint_files(Path(out) / "checkpoints")[-1]
    history = load_checkpoint(newest)["history"]["train"][1:]
    return 1000.0 / (sum(r["ms_per_step"] for r in history) / len(history))


def scaling(one, two):
    """Throughputs with 1 and 2 workers or processes, the speedup, and the scaling efficiency
    (speedup / 2: 1.0 is perfect scaling when doubling the workers doubles the cores)."""
    return {"one": one, "two": two, "speedup": two / one, "efficiency": two / (2 * one)}


@click.command()
@click.option("--spp", default=256, show_default=True)
@click.option("--render-size", default=256, show_default=True)
@click.option("--rotations", default=4, show_default=True)
@click.option("--steps", default=60, show_default=True, help="Training steps per run (>= 20).")
def main(spp, render_size, rotations, steps):
    work = Path(tempfile.mkdtemp(prefix="scaling-"))
    base = DatasetConfig(probes=str(REPO / "probes"), svbrdfs=str(REPO / "scenes" / "materials"),
                         out="", resolution=64, render_size=render_size, rotations=rotations,
                         crops=steps * 16 // (9 * rotations) + 1, spp=spp, test_materials=0,
                         test_probes=0)
    samples_per_second = {}
    for name, changes in (("local 1", {"workers": 1}), ("local 2", {"workers": 2}),
                          ("ray 1", {"workers": 1, "ray": "local"}),
                          ("ray 2", {"workers": 2, "ray": "local"})):
        cfg = dataclasses.replace(base, out=str(work / name.replace(" ", "-")), **changes)
        ray_start = ray_start_seconds(cfg.workers) if cfg.ray else 0.0
        seconds, count = render_seconds(cfg)
        samples_per_second[name] = {"samples": count, "seconds": seconds,
                                    "ray_start_seconds": ray_start,
                                    "samples_per_second": count / seconds}
        if cfg.ray:
            import ray

            ray.shutdown()
    dataset = work / "local-1"
    steps_per_log = 10
    train = {processes: training_steps_per_second(dataset, work / f"train-{processes}",
                                                  processes, steps_per_log)
             for processes in (1, 2)}
    rate = {name: value["samples_per_second"] for name, value in samples_per_second.items()}
    print(json.dumps({
        "benchmark": "scaling", "machine": platform.processor() or platform.machine(),
        "cpus": os.cpu_count(), "spp": spp, "render_size": render_size,
        "render": samples_per_second,
        "render_scaling_local": scaling(rate["local 1"], rate["local 2"]),
        "render_scaling_ray": scaling(rate["ray 1"], rate["ray 2"]),
        "train_steps_per_second": scaling(train[1], train[2]),
    }, indent=2))


if __name__ == "__main__":
    main()
