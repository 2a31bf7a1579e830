"""The release: every shipped SVBRDF-net file and the model card's tables, rebuilt by one
command from the repository and ``../shared/data`` (issue 50, "one reproducible release").

    .venv/bin/python scripts/release.py --out WORK [--size full|cpu|toy] [--train-minutes M] \
        [--device cpu|cuda] [--parallel N] [--shared SHARED_DATA]

RECIPE names the networks and, for each, its stages: the procedural sets each stage trains on
(make-materials class and seeds) and its sa-train options. A network is a chain of sa-train
runs, the shipped files' stages (models/README.md): the first from scratch, each later one
fine-tuning the export of the one before. Labeled minibatches are rendered on the fly under the
training probes (the shared probes less the 8 that scripts/real_validation.py holds out). No
run sees a real set or a held-out probe: the real sets are the validation folds and the test of
scripts/real_validation.py.

Into WORK, each step kept where done, so that the same command continues a cut-off release:

    size.txt                      the size the folder was made at (another is refused)
    sets/<class>-<seed>/          make-materials sets
    maps/<network>-<stage>/       links to the material folders of one stage's run
    runs/<network>-<stage>/       sa-train runs (each resumes from its newest checkpoint;
                                  <network>-<stage>.init: the digest of the file it started
                                  from, so that a run started from an older export of the
                                  stage before starts again)
    stages/<network>-<stage>.safetensors   the exports later stages start from
    files/svbrdf-<network>.safetensors   each network's last stage, exported: the released
                                  files
    validation/, test/            scripts/real_validation.py evaluations and tables of every
                                  sa-estimate --class choice (the networks, and unknown:
                                  plastic's maps with the fixed lobe), on ``--device`` too
                                  (an evaluation of an older export is made again); on the
                                  validation the shipped files' choices beside them
                                  (shipped-<choice>), the ship rule's bars
    procedural/                   scripts/procedural_test.py: the card's larger procedural
                                  test, each network and the shipped file of its class on the
                                  same Mitsuba renders (release/, shipped/)
    card.md, release.json         the card's tables: each run's steps and minutes, the
                                  validation per fold and choice, the test, the larger test,
                                  and whether the files pass the ship rule of
                                  models/README.md (ship_rule_failures)

Time: the networks share ``--train-minutes``. Each is given the share of the minutes left that
its steps left (over its stages) are of the steps left of the networks whose turn in this call
is not over (times ``--parallel``, the networks trained at once; the last gets what is left),
and its stages train in order until that is spent (the run training then stops after its step,
checkpointed); the newest checkpoint of each network's last stage, where it has one, is then
exported and card.md says how many of its steps each network reached. A later call continues the
runs towards their steps; the validation, the test and the larger test are measured once every
run has all its steps (an unfinished release's card has the runs' table only; on a 2-core CPU
the real sets take 15 to 26 minutes and the shipped files' validation 15 more, the larger test
about an hour, half of it Mitsuba's renders). SIGTERM or Ctrl-C while the runs train stops the
call the same way: the sa-train running writes the checkpoint of its step, no other run starts,
the card is written, and the call exits with status 128 + the signal's number. ``--size toy`` is
the same pipeline on a few small sets, a small network and a few photos (minutes on a CPU; the
tests run it); ``full`` is the release on a GPU, ``cpu`` the same at a sixteenth of the steps in
shorter epochs (SIZES).

The released files are not copied into models/: the shipped files change when a release's
validation says they should (models/README.md).
"""

import dataclasses
import json
import math
import os
import platform
import shutil
import signal
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import click
import torch

from render.common.atomic_files import atomic_path, write_json
from render.common.errors import InputError
from render.common.resume import file_digest
from train.estimation.network_choice import CLASSES, class_model_file, network_choice
from train.networks.checkpoints import checkpoint_files, checkpoint_step, newest_step
from train.networks.model_files import FORMAT, load_network, model_metadata, save_model
from train.training.interruption import SIGNALS, StopRequest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from compare_evaluations import compare, per_photo  # noqa: E402
from procedural_test import SIZES as PROCEDURAL_SIZES  # noqa: E402
from procedural_test import evaluate_class, render_test  # noqa: E402
from real_validation import (  # noqa: E402
    SHARED,
    TEST_PROBES,
    VALIDATION_PROBES,
    evaluate_choice,
    linked_folder,
    split_folds,
    summarize,
)

BIN = Path(sys.executable).parent
"""The environment's commands (make-materials, sa-train)."""


@dataclass(frozen=True)
class Stage:
    """One sa-train run of a network's chain. The first starts from scratch; every later one
    fine-tunes the export of the stage before it (sa-train --init-from, a fresh optimizer)."""

    steps: int
    """Optimizer steps at size full."""
    seeds: tuple[int, ...]
    """make-materials seeds of its sets (seed 1 makes the procedural test's sets)."""
    options: tuple[str, ...] = ()
    """sa-train options beyond the common ones (train_command); a later --learning-rate
    replaces the common one."""


@dataclass(frozen=True)
class Network:
    """One released file, svbrdf-<name>.safetensors: the last stage's export."""

    name: str
    """Its material class too: make-materials --class of its sets."""
    stages: tuple[Stage, ...]


ALL_SEEDS = (0, 2, 3, 4, 5, 6, 7, 8)
FOUR_SEEDS = (0, 2, 3, 4)
MORE_TEXTURES = (*FOUR_SEEDS, 10)
SETS_AT_FULL = {10: 1000}
"""make-materials sets of a seed at size full where not 50 (Size.sets_per_seed scales them):
seed 10 makes plastic's 1,000 more textures."""
FINE_TUNE = ("--learning-rate", "0.0005")
PHOTO_AFFINE = ("--albedo-network", "photo-affine")
RELIT = ("--relit-loss-weight", "300")
BEFORE_PHOTO_AFFINE = ("--train-networks", "normal,homogeneous")
"""Plastic's stages before its photo-affine albedo network: that network replaces the albedo
network (its analysis starts from the homogeneous one's), so the stages before it leave the
albedo network untrained (the others train bit for bit as beside it, a third less time)."""

RECIPE = (
    Network("wood", (Stage(1800, ALL_SEEDS), Stage(2800, ALL_SEEDS, FINE_TUNE))),
    Network("plastic", (
        Stage(2000, ALL_SEEDS, BEFORE_PHOTO_AFFINE),
        Stage(3000, ALL_SEEDS, (*BEFORE_PHOTO_AFFINE, *FINE_TUNE)),
        Stage(1600, FOUR_SEEDS, ("--train-networks", "homogeneous", "--mix-specular",
                                 *RELIT, *FINE_TUNE)),
        Stage(1200, FOUR_SEEDS, ("--train-networks", "albedo", "--mix-specular",
                                 "--learning-rate", "0.001", *PHOTO_AFFINE)),
        Stage(800, FOUR_SEEDS, ("--train-networks", "albedo,homogeneous", "--mix-specular",
                                *RELIT, *FINE_TUNE, *PHOTO_AFFINE)),
        Stage(800, MORE_TEXTURES, ("--train-networks", "homogeneous", "--mix-specular",
                                   *RELIT, *FINE_TUNE, *PHOTO_AFFINE)),
        Stage(800, MORE_TEXTURES, ("--train-networks", "homogeneous", "--mix-specular",
                                   *RELIT, *FINE_TUNE, *PHOTO_AFFINE)),
        Stage(800, MORE_TEXTURES, ("--train-networks", "albedo", "--mix-specular", *RELIT,
                                   "--relit-partners", "estimate", *FINE_TUNE, *PHOTO_AFFINE)),
    )),
    Network("metal", (Stage(2000, ALL_SEEDS),
                      Stage(1200, FOUR_SEEDS, ("--train-networks", "homogeneous", *RELIT,
                                               *FINE_TUNE)))),
)
"""The networks of a release and how each is trained: the shipped files' stages
(models/README.md), each an sa-train run; own specular pairs unless --mix-specular (every
texture seen with every set's pair). Plastic's fourth stage as it was made, a U-Net albedo
network that the next stage replaced by a new photo-affine one, is left out (it changed no
weight kept), so its later stages are numbered one lower here than in the files' metadata;
its first two stages, which trained the albedo network that stage 4 replaces, train the other
two alone here (BEFORE_PHOTO_AFFINE)."""


SHIPPED = "shipped-"
"""Prefix of the validation's evaluations of the shipped files' --class choices (the ship
rule's bars, measured on the same photos as the release's)."""
WORST_SET_RELIT = 1.10
"""No validation set's relit ratio under a release's default estimate may exceed this."""


@dataclass(frozen=True)
class Size:
    sets_per_seed: int
    """make-materials sets of each class and seed (50 at size full; SETS_AT_FULL's seeds in
    proportion)."""
    resolution: int
    """Side (px) of the procedural maps."""
    network: str
    """sa-train --network preset."""
    step_fraction: float
    """Share of each network's full-size steps a run trains (rounded up to whole epochs)."""
    epoch_samples: int
    batch_size: int
    render_size: int
    """sa-train --render-size."""
    checkpoint_every: int
    photos: int
    """Validation (and test) photos per fold and network."""
    relights: int
    procedural_test: str
    """Size of scripts/procedural_test.py's test."""


SIZES = {"full": Size(50, 512, "compact", 1.0, 3200, 16, 512, 100, 60, 3, "full"),
         "cpu": Size(50, 512, "compact", 0.0625, 1600, 16, 512, 100, 60, 3, "full"),
         "toy": Size(1, 64, "small", 0.0005, 16, 4, 128, 2, 2, 1, "toy")}
"""``full`` is the shipped files' recipe (18,800 steps), meant for a GPU; ``cpu`` trains a
sixteenth of each stage's steps in epochs of 100 steps (1,700 steps, about 80 minutes of a
2-core CPU, so that the training fits one working session there; the measurement and the larger
test's renders come on top); ``toy`` runs in minutes (the tests)."""


def check_size(work: Path, size_name: str) -> None:
    """Note the size of a new work folder in work/size.txt; refuse another size (its runs'
    epochs differ, so no run of one size continues into another)."""
    mark = work / "size.txt"
    if not mark.is_file():
        with atomic_path(mark) as tmp:
            tmp.write_text(size_name)
    elif mark.read_text() != size_name:
        raise InputError(work, f"made at size {mark.read_text()}, not {size_name}: use a new "
                               "work folder")


def training_probes(shared: Path) -> list[str]:
    """Names of the shared probes no validation or test photo is lit or relit by."""
    held_out = set(VALIDATION_PROBES) | set(TEST_PROBES)
    return sorted(p.stem for p in (shared / "probes").glob("*.exr") if p.stem not in held_out)


def training_probe_folder(work: Path, shared: Path) -> Path:
    """work/probes-training: links to the probes of training_probes."""
    return linked_folder(work / "probes-training",
                         [f"{name}.exr" for name in training_probes(shared)], shared / "probes")


def total_steps(stage: Stage, size: Size) -> int:
    """Optimizer steps of a stage's run: whole epochs of ``size.epoch_samples``."""
    per_epoch = size.epoch_samples // size.batch_size
    return math.ceil(stage.steps * size.step_fraction / per_epoch) * per_epoch


def network_steps(network: Network, size: Size) -> int:
    """Optimizer steps of all a network's stages."""
    return sum(total_steps(stage, size) for stage in network.stages)


def set_count(seed: int, size: Size) -> int:
    """make-materials sets of ``seed`` at ``size`` (SETS_AT_FULL, 50 by default, scaled)."""
    return max(1, SETS_AT_FULL.get(seed, 50) * size.sets_per_seed // 50)


def make_sets(work: Path, size: Size, parallel: int) -> None:
    """make-materials every class and seed of RECIPE into work/sets (kept sets are skipped)."""
    jobs = sorted({(network.name, seed) for network in RECIPE for stage in network.stages
                   for seed in stage.seeds})

    def make(job):
        material_class, seed = job
        subprocess.run([str(BIN / "make-materials"), "--class", material_class,
                        "--count", str(set_count(seed, size)), "--seed", str(seed),
                        "--resolution", str(size.resolution),
                        "--out", str(work / "sets" / f"{material_class}-{seed}")],
                       check=True, stdout=subprocess.DEVNULL)

    with ThreadPoolExecutor(max(1, parallel)) as pool:
        list(pool.map(make, jobs))


def maps_folder(work: Path, network: Network, index: int) -> Path:
    """work/maps/<network>-<stage>: links to the material folders a stage trains on."""
    folder = work / "maps" / stage_name(network, index)
    for seed in network.stages[index].seeds:
        sets = work / "sets" / f"{network.name}-{seed}"
        linked_folder(folder, [p.name for p in sorted(sets.iterdir()) if p.is_dir()], sets)
    return folder


def stage_name(network: Network, index: int) -> str:
    """<network>-<stage>, stages counted from 1: the name of its run and maps folders."""
    return f"{network.name}-{index + 1}"


def train_command(work: Path, network: Network, index: int, maps: Path, size: Size,
                  device: str, init: Path | None) -> list[str]:
    """The sa-train call of a stage's run on the material folders in ``maps``, from ``init``
    (the previous stage's export) unless it is the first."""
    stage = network.stages[index]
    epochs = total_steps(stage, size) * size.batch_size // size.epoch_samples
    return [str(BIN / "sa-train"),
            "--labeled-maps", str(maps),
            "--probes", str(work / "probes-training"),
            "--out", str(run_folder(work, network, index)),
            *(("--init-from", str(init)) if init else ()),
            "--network", size.network, "--render-size", str(size.render_size),
            "--labeled-epochs", str(epochs), "--self-augmented-epochs", "0",
            "--epoch-samples", str(size.epoch_samples), "--batch-size", str(size.batch_size),
            "--learning-rate", "0.002", "--lr-gamma", "1e-3",
            "--checkpoint-every", str(size.checkpoint_every), "--log-every", "50",
            "--device", device, *stage.options]


def run_folder(work: Path, network: Network, index: int) -> Path:
    return work / "runs" / stage_name(network, index)


def reached_steps(work: Path, network: Network, size: Size) -> list[int]:
    """Steps each stage's run has reached; a stage counts only once every stage before it has
    all its steps (until then its start is not final: see fresh_run)."""
    reached, complete = [], True
    for index, stage in enumerate(network.stages):
        steps = newest_step(run_folder(work, network, index) / "checkpoints") if complete else 0
        reached.append(steps)
        complete = complete and steps >= total_steps(stage, size)
    return reached


def fresh_run(work: Path, network: Network, index: int, init: Path) -> None:
    """Remove a stage's run (and its export) if it started from another file than ``init``,
    the previous stage's current export (as when RECIPE gave the stage before more steps
    since), so that it starts again; note ``init``'s digest for a new run."""
    run = run_folder(work, network, index)
    noted = run.with_suffix(".init")
    digest = file_digest(init)
    if noted.is_file() and noted.read_text() != digest:
        shutil.rmtree(run, ignore_errors=True)
        stage_file(work, network, index).unlink(missing_ok=True)
    run.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(noted) as tmp:
        tmp.write_text(digest)


def train_runs(work: Path, size: Size, device: str, minutes: float, parallel: int,
               command: str) -> tuple[dict[str, dict], int | None]:
    """Train (or continue) every network's stages, in order, within ``minutes``; returns
    ({network: steps, seconds}, the signal that stopped the call or None).

    SIGTERM or SIGINT to this process (or to a run's sa-train) stops the call: each sa-train
    running writes the checkpoint of its step (train/training/interruption.py), no further run
    starts, and the same command continues."""
    deadline = time.monotonic() + 60.0 * minutes
    threads = str(max(1, (os.cpu_count() or 1) // max(1, parallel)))
    record = {}
    waiting = {network.name for network in RECIPE}  # networks whose turn in this call is not over
    stop = StopRequest()  # taken while the runs train
    stopped_by = []  # the signal that stopped a run's sa-train, once one has

    def steps_left(network):
        return network_steps(network, size) - sum(reached_steps(work, network, size))

    def run_stage(network, index, end):
        """Train one stage until its steps, ``end`` or a stop; raise if sa-train fails."""
        init = None
        if index:
            init = export(work, network, index - 1, size, command)
            fresh_run(work, network, index, init)
        log = run_folder(work, network, index).with_suffix(".log")
        log.parent.mkdir(parents=True, exist_ok=True)
        call = train_command(work, network, index, maps_folder(work, network, index), size,
                             device, init)
        with open(log, "a") as output:
            process = subprocess.Popen(call, stdout=output, stderr=subprocess.STDOUT,
                                       env=os.environ | {"OMP_NUM_THREADS": threads})
            recorded = time.monotonic()
            while process.poll() is None and time.monotonic() < end and not stop.requested:
                try:
                    process.wait(timeout=1.0)
                except subprocess.TimeoutExpired:
                    if time.monotonic() - recorded >= 60.0:
                        recorded = time.monotonic()
                        record_seconds(network)
            if process.poll() is None:
                process.terminate()  # sa-train writes the checkpoint of its step and
                process.wait()  # exits (a second signal, as after Ctrl-C, is ignored)
            elif process.returncode - 128 in SIGNALS:
                stopped_by.append(process.returncode - 128)  # signalled, checkpoint kept
            elif process.returncode:
                raise InputError(log, f"sa-train failed (exit status {process.returncode})")

    started, before = {}, {}

    def record_seconds(network) -> float:
        # Written every minute, so that a call killed by SIGKILL keeps its time too.
        seconds = before[network.name] + time.monotonic() - started[network.name]
        with atomic_path(seconds_file(work, network)) as tmp:
            tmp.write_text(f"{seconds:.1f}")
        return seconds

    def train(network):
        allowance = time_share(deadline - time.monotonic(), parallel, steps_left(network),
                               sum(steps_left(n) for n in RECIPE if n.name in waiting))
        started[network.name] = time.monotonic()
        end = started[network.name] + allowance
        timing = seconds_file(work, network)
        timing.parent.mkdir(parents=True, exist_ok=True)
        before[network.name] = float(timing.read_text()) if timing.is_file() else 0.0
        for index, stage in enumerate(network.stages):
            if reached_steps(work, network, size)[index] >= total_steps(stage, size):
                continue
            if time.monotonic() >= end or stop.requested or stopped_by:
                break
            run_stage(network, index, end)
            if reached_steps(work, network, size)[index] < total_steps(stage, size):
                break  # out of time or stopped: a later call continues it
        record[network.name] = {"steps": network_steps(network, size) - steps_left(network),
                                "of_steps": network_steps(network, size),
                                "seconds": round(record_seconds(network), 1)}
        waiting.discard(network.name)
        click.echo(json.dumps({"run": network.name, **record[network.name]}))

    with stop, ThreadPoolExecutor(max(1, parallel)) as pool:
        list(pool.map(train, RECIPE))
    return record, stop.signal_number or (stopped_by[0] if stopped_by else None)


def seconds_file(work: Path, network: Network) -> Path:
    """work/runs/<network>.seconds: the seconds its stages have trained, over every call."""
    return work / "runs" / f"{network.name}.seconds"


def time_share(seconds_left: float, parallel: int, steps_left: int,
               steps_left_waiting: int) -> float:
    """Seconds a run may train: of the ``seconds_left`` (times ``parallel``, the runs trained at
    once), the share its steps left are of those of every run whose turn in this call is not
    over (``steps_left_waiting``, its own included), and never past the deadline."""
    share = seconds_left * parallel * steps_left / max(1, steps_left_waiting)
    return min(share, seconds_left)


def export(work: Path, network: Network, index: int, size: Size, command: str) -> Path:
    """The export of a stage's newest checkpoint: work/stages/<network>-<stage>.safetensors,
    the last stage's work/files/svbrdf-<network>.safetensors (written again only when the run
    has a newer checkpoint)."""
    path = stage_file(work, network, index)
    run = run_folder(work, network, index)
    newest = checkpoint_files(run / "checkpoints")
    if not newest:
        raise InputError(run, "no checkpoint to export: give the training more minutes")
    if path.is_file() and model_metadata(path, FORMAT, "model").get(
            "trained_from") == newest[-1].name:
        return path
    net = load_network(newest[-1])
    earlier = sum(total_steps(stage, size) for stage in network.stages[:index])
    path.parent.mkdir(parents=True, exist_ok=True)
    save_model(net, path, {
        "class": network.name, "trained_from": newest[-1].name,
        "command": command,
        "recipe": json.dumps(dataclasses.asdict(network)),
        "steps": f"{earlier + checkpoint_step(newest[-1])} of {network_steps(network, size)}",
        "stage": f"{index + 1} of {len(network.stages)}"})
    return path


def export_files(work: Path, size: Size, command: str) -> list[str]:
    """Export each network's last stage where its run has a checkpoint (a network whose last
    stage has not started has no file yet); returns the networks exported."""
    exported = []
    for network in RECIPE:
        last = len(network.stages) - 1
        if checkpoint_files(run_folder(work, network, last) / "checkpoints"):
            export(work, network, last, size, command)
            exported.append(network.name)
    return exported


def stage_file(work: Path, network: Network, index: int) -> Path:
    """Where a stage's run is exported: the last stage's file is the released one
    (exported_file), the others' work/stages/<network>-<stage>.safetensors."""
    if index == len(network.stages) - 1:
        return exported_file(work, network)
    return work / "stages" / f"{stage_name(network, index)}.safetensors"


def exported_file(work: Path, network: Network) -> Path:
    """work/files/svbrdf-<network>.safetensors: the released file of a network (the file its
    --class choice estimates with, among the release's files)."""
    return class_model_file(network.name, work / "files")


def evaluate(work: Path, split: str, size: Size, shared: Path, device: str) -> dict:
    """scripts/real_validation.py's evaluation of every --class choice (each network, and the
    estimate for a material of unknown kind: plastic's maps with the fixed lobe) on ``split``,
    into work/<split>, on the torch ``device``; on the validation the shipped files' choices
    too, on the same photos (named SHIPPED + choice). An evaluation of another file than the
    current export (or the current shipped file) is made again."""
    out, folds = work / split, list(split_folds(split))
    evaluations = {choice: work / "files" for choice in CLASSES}
    if split == "validation":
        evaluations |= {SHIPPED + choice: None for choice in CLASSES}
    for name, models in evaluations.items():
        choice = name.removeprefix(SHIPPED)
        for fold in folds:
            drop_stale(out / fold / name, class_model_file(choice, models))
        evaluate_choice(out, split, name,
                        lambda fold, c=choice, m=models: network_choice(None, c, device, m),
                        size.photos, size.relights, shared=shared, device=device)
    return summarize(out, folds, list(evaluations))


def drop_stale(evaluation: Path, model_file: Path) -> None:
    """Remove the sa-evaluate folder ``evaluation`` if it evaluated another file than
    ``model_file`` (an older export), so that it is made again."""
    config = evaluation / "config.json"
    if config.is_file():
        models = json.loads(config.read_text()).get("models", {})
        if file_digest(model_file) not in models.values():
            shutil.rmtree(evaluation)


def procedural_table(work: Path, size: Size, shared: Path, device: str) -> list[dict]:
    """scripts/procedural_test.py in work/procedural: each network of the release and the
    shipped file of its class on the same renders; per class both ratios (relit RMSE over the
    naive baseline's), their paired difference with its standard error, and the spread of the
    release's ratio over the sets (scripts/compare_evaluations.py)."""
    test, test_size, rows = work / "procedural", PROCEDURAL_SIZES[size.procedural_test], []
    for network in RECIPE:
        renders, results = render_test(test, test_size, network.name, shared), {}
        for name, models in (("shipped", None), ("release", work / "files")):
            drop_stale(test / name / network.name, class_model_file(network.name, models))
            results[name] = per_photo(evaluate_class(test, test_size, network.name, renders,
                                                     models, name, shared, device),
                                      "relit_rmse")
        rows.append({"network": network.name,
                     **compare(results["shipped"], results["release"], draws=4000, seed=0)})
    return rows


def ship_rule_failures(validation: dict, procedural: list[dict]) -> list[str]:
    """The ship rule of models/README.md, fixed before a release is measured: its files
    replace the shipped ones if, on the real validation (``validation``: summarize's table of
    the release's and the shipped files' choices, SHIPPED + choice), each --class choice
    relights at or below the shipped one's, the default estimate's albedo is at or below the
    shipped default's and no set's relit ratio under it is above WORST_SET_RELIT, and on the
    larger test (``procedural``: procedural_table's rows) no network is worse than the shipped
    file by more than its spread over sets. Returns the checks that fail, in words (none: the
    files ship)."""
    every = validation["folds"]["all"]
    failures = [f"{choice} relights the validation at {every[choice]['relit_ratio']:.3f}x, "
                f"above the shipped {every[SHIPPED + choice]['relit_ratio']:.3f}x"
                for choice in CLASSES
                if every[choice]["relit_ratio"] > every[SHIPPED + choice]["relit_ratio"]]
    default, shipped_default = every["unknown"], every[SHIPPED + "unknown"]
    if default["albedo_ratio"] > shipped_default["albedo_ratio"]:
        failures.append(f"the default's albedo is {default['albedo_ratio']:.3f}x, above the "
                        f"shipped {shipped_default['albedo_ratio']:.3f}x")
    if default["worst_relit_ratio"] > WORST_SET_RELIT:
        failures.append(f"the default relights {default['worst_set']} at "
                        f"{default['worst_relit_ratio']:.3f}x, above {WORST_SET_RELIT:.2f}x")
    failures += [f"{row['network']} on the larger test: {row['new_ratio']:.3f}x against the "
                 f"shipped file's {row['base_ratio']:.3f}x, worse by more than its spread "
                 f"({row['new_ratio_bootstrap_sd']:.3f})"
                 for row in procedural
                 if row["paired_difference"] > row["new_ratio_bootstrap_sd"]]
    return failures


def procedural_markdown(rows: list[dict]) -> str:
    """The procedural test's table in markdown."""
    lines = ["| network | photos | shipped file | release | release - shipped (se) | "
             "release's spread over sets (sd) |", "| --- | --- | --- | --- | --- | --- |"]
    lines += [f"| {row['network']} | {row['photos']} | {row['base_ratio']:.3f} | "
              f"{row['new_ratio']:.3f} | {row['paired_difference']:+.3f} "
              f"({row['standard_error']:.3f}) | {row['new_ratio_bootstrap_sd']:.3f} |"
              for row in rows]
    return "\n".join(lines)


def write_card(work: Path, command: str, record: dict, tables: dict | None) -> None:
    """card.md and release.json: the machine, the runs, and the validation, the test, the
    larger test and the ship rule's failed checks (``tables``; None while a run is
    unfinished)."""
    lines = [f"Made by `{command}` on {machine()}.", "", "| run | steps | minutes |",
             "| --- | --- | --- |"]
    lines += [f"| {name} | {row['steps']} of {row['of_steps']} | {row['seconds'] / 60:.1f} |"
              for name, row in record.items()]
    if tables is None:
        lines += ["", "Unfinished: the same command continues the runs; the validation, the "
                      "test and the larger test are measured when every run has all its steps."]
    for split in ("validation", "test") if tables else ():
        lines += ["", f"**{split}** (relit and albedo RMSE over the naive baseline's)", "",
                  (work / split / "table.md").read_text()]
    if tables:
        lines += ["", "**procedural larger test** (relit RMSE over the naive baseline's; "
                      "scripts/procedural_test.py)", "", procedural_markdown(tables["procedural"])]
        failures = tables["ship_rule_failures"]
        lines += ["", "**Ship rule** (models/README.md): " + (
            "every check holds: these files replace the shipped ones." if not failures else
            "these files do not replace the shipped ones:"), *[f"- {f}" for f in failures]]
    with atomic_path(work / "card.md") as tmp:
        tmp.write_text("\n".join(lines) + "\n")
    write_json(work / "release.json", {"command": command, "machine": machine(),
                                       "runs": record, **(tables or {})})


def machine() -> str:
    """The machine in words: CPU cores and, where torch sees one, the GPU."""
    words = f"{os.cpu_count()} CPU cores ({platform.machine()})"
    if torch.cuda.is_available():
        words += f", {torch.cuda.get_device_name(0)}"
    return words


@click.command()
@click.option("--out", required=True, type=click.Path(), help="Work folder (resumable).")
@click.option("--size", "size_name", type=click.Choice(sorted(SIZES)), default="full",
              show_default=True)
@click.option("--train-minutes", default=480.0, show_default=True,
              help="Minutes the training runs share.")
@click.option("--device", default="cpu", show_default=True, help="torch device of the runs.")
@click.option("--parallel", default=1, show_default=True, type=click.IntRange(min=1),
              help="Runs trained at once (one per GPU share or core group).")
@click.option("--shared", default=str(SHARED), show_default=True, type=click.Path(),
              help="The shared data folder (svbrdfs/, probes/).")
def main(out, size_name, train_minutes, device, parallel, shared):
    work, shared, size = Path(out), Path(shared), SIZES[size_name]
    # The files' and the card's command: a release continues over calls whose minutes and
    # parallel runs differ, and neither changes what the runs compute, only how far they get
    # (each file's metadata says its steps, the card each run's minutes).
    command = f"scripts/release.py --size {size_name} --device {device}"
    try:
        for folder in ("svbrdfs", "probes"):
            if not (shared / folder).is_dir():
                raise InputError(shared / folder, "not found (the shared data folder is needed)")
        work.mkdir(parents=True, exist_ok=True)
        check_size(work, size_name)
        training_probe_folder(work, shared)
        make_sets(work, size, parallel)
        record, stopped_by = train_runs(work, size, device, train_minutes, parallel, command)
        if stopped_by:
            write_card(work, command, record, None)
            click.echo(f"release.py: stopped by {signal.Signals(stopped_by).name}: each run "
                       f"keeps the checkpoint of its step, the same command continues", err=True)
            raise SystemExit(128 + stopped_by)
        export_files(work, size, command)
        finished = all(row["steps"] >= row["of_steps"] for row in record.values())
        tables = None
        if finished:
            tables = {split: evaluate(work, split, size, shared, device)
                      for split in ("validation", "test")}
            tables["procedural"] = procedural_table(work, size, shared, device)
            tables["ship_rule_failures"] = ship_rule_failures(tables["validation"],
                                                              tables["procedural"])
        write_card(work, command, record, tables)
    except InputError as error:
        raise click.ClickException(str(error)) from None
    click.echo((work / "card.md").read_text())


if __name__ == "__main__":
    main()
