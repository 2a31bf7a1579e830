"""The release: every shipped SVBRDF-net file and the model card's tables, rebuilt by one
command from the repository and ``../shared/data`` (issue 50, "one reproducible release").

    .venv/bin/python scripts/release.py --out WORK [--size full|cpu|toy] [--train-minutes M] \
        [--device cpu|cuda] [--parallel N] [--shared SHARED_DATA]

RECIPE names the networks: the procedural sets each trains on (make-materials class and
seeds) and its sa-train options; every network is one sa-train run from scratch, labeled
minibatches rendered on the fly under the training probes (the shared probes less the 8 that
scripts/real_validation.py holds out). No run sees a real set or a held-out probe: the real
sets are the validation folds and the test of scripts/real_validation.py.

Into WORK, each step kept where done, so that the same command continues a cut-off release:

    sets/<class>-<seed>/          make-materials sets
    maps/<network>/               links to the material folders of one run
    runs/<network>/               sa-train runs (each resumes from its newest checkpoint)
    files/svbrdf-<network>.safetensors   each run's newest checkpoint, exported: the released
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

Time: the runs share ``--train-minutes``. Each is given the share of the minutes left that its
steps left are of the steps left of the runs whose turn in this call is not over (times
``--parallel``, the runs trained at once; the last run gets what is left), and stopped (after
its step, checkpointed) when that is spent; its newest checkpoint is then exported and card.md
says how many of its steps it reached. A later call continues the runs towards their steps; the
validation, the test and the larger test are measured once every run has all its steps (an
unfinished release's card has the runs' table only; on a 2-core CPU the real sets take 15 to 26
minutes and the shipped files' validation 15 more, the larger test about an hour, half of it
Mitsuba's renders). SIGTERM or Ctrl-C while the runs train stops the call the same way: the
sa-train running writes the checkpoint of its step, no other run starts, the card is written,
and the call exits with status 128 + the signal's number. ``--size toy`` is the same pipeline on
a few small sets, a small network and a few photos (minutes on a CPU; the tests run it);
``full`` is the release on a GPU, ``cpu`` the same at an eighth of the steps (SIZES). A work
folder of size ``cpu`` continues into size ``full``: the same sets, and each run's steps so far
are the first steps of its longer run (sa-train continues a run into more labeled epochs), so a
CPU can grow a release over several calls.

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
class Network:
    """One released file, svbrdf-<name>.safetensors."""

    name: str
    """Its material class too: make-materials --class of its sets."""
    seeds: tuple[int, ...]
    """make-materials seeds of its sets (seed 1 makes the procedural test's sets)."""
    steps: int
    """Optimizer steps at size full."""
    options: tuple[str, ...] = ()
    """sa-train options beyond the common ones (Size, train_command)."""


SEEDS = (0, 2, 3, 4, 5, 6, 7, 8)
RECIPE = (
    Network("wood", SEEDS, 4600, ("--own-specular",)),
    Network("plastic", SEEDS, 4600,
            ("--mix-specular", "--albedo-network", "photo-affine", "--relit-loss-weight", "300")),
    Network("metal", SEEDS, 3200, ("--own-specular", "--relit-loss-weight", "300")),
)
"""The networks of a release and how each is trained."""


SHIPPED = "shipped-"
"""Prefix of the validation's evaluations of the shipped files' --class choices (the ship
rule's bars, measured on the same photos as the release's)."""
WORST_SET_RELIT = 1.10
"""No validation set's relit ratio under a release's default estimate may exceed this."""


@dataclass(frozen=True)
class Size:
    sets_per_seed: int
    """make-materials sets of each class and seed."""
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
         "cpu": Size(50, 512, "compact", 0.125, 3200, 16, 512, 100, 60, 3, "full"),
         "toy": Size(1, 64, "small", 0.0005, 16, 4, 128, 2, 2, 1, "toy")}
"""``full`` is meant for one GPU call (12,400 steps); ``cpu`` trains an eighth of the steps,
about 85 minutes of a 2-core CPU, so that a release fits one working session there (the larger
test's renders, made once per work folder, come on top); ``toy`` runs in minutes (the tests)."""


def training_probes(shared: Path) -> list[str]:
    """Names of the shared probes no validation or test photo is lit or relit by."""
    held_out = set(VALIDATION_PROBES) | set(TEST_PROBES)
    return sorted(p.stem for p in (shared / "probes").glob("*.exr") if p.stem not in held_out)


def training_probe_folder(work: Path, shared: Path) -> Path:
    """work/probes-training: links to the probes of training_probes."""
    return linked_folder(work / "probes-training",
                         [f"{name}.exr" for name in training_probes(shared)], shared / "probes")


def total_steps(network: Network, size: Size) -> int:
    """Optimizer steps of a run: whole epochs of ``size.epoch_samples``."""
    per_epoch = size.epoch_samples // size.batch_size
    return math.ceil(network.steps * size.step_fraction / per_epoch) * per_epoch


def make_sets(work: Path, size: Size, parallel: int) -> None:
    """make-materials every class and seed of RECIPE into work/sets (kept sets are skipped)."""
    jobs = [(network.name, seed) for network in RECIPE for seed in network.seeds]

    def make(job):
        material_class, seed = job
        subprocess.run([str(BIN / "make-materials"), "--class", material_class,
                        "--count", str(size.sets_per_seed), "--seed", str(seed),
                        "--resolution", str(size.resolution),
                        "--out", str(work / "sets" / f"{material_class}-{seed}")],
                       check=True, stdout=subprocess.DEVNULL)

    with ThreadPoolExecutor(max(1, parallel)) as pool:
        list(pool.map(make, jobs))


def maps_folder(work: Path, network: Network) -> Path:
    """work/maps/<network>: links to the material folders the network trains on."""
    folder = work / "maps" / network.name
    for seed in network.seeds:
        sets = work / "sets" / f"{network.name}-{seed}"
        linked_folder(folder, [p.name for p in sorted(sets.iterdir()) if p.is_dir()], sets)
    return folder


def train_command(work: Path, network: Network, maps: Path, size: Size,
                  device: str) -> list[str]:
    """The sa-train call of one run on the material folders in ``maps``."""
    epochs = total_steps(network, size) * size.batch_size // size.epoch_samples
    return [str(BIN / "sa-train"),
            "--labeled-maps", str(maps),
            "--probes", str(work / "probes-training"),
            "--out", str(run_folder(work, network)),
            "--network", size.network, "--render-size", str(size.render_size),
            "--labeled-epochs", str(epochs), "--self-augmented-epochs", "0",
            "--epoch-samples", str(size.epoch_samples), "--batch-size", str(size.batch_size),
            "--learning-rate", "0.002", "--lr-gamma", "1e-3",
            "--checkpoint-every", str(size.checkpoint_every), "--log-every", "50",
            "--device", device, *network.options]


def run_folder(work: Path, network: Network) -> Path:
    return work / "runs" / network.name


def train_runs(work: Path, size: Size, device: str, minutes: float,
               parallel: int) -> tuple[dict[str, dict], int | None]:
    """Train (or continue) every network's run within ``minutes``; returns ({network: steps,
    seconds}, the signal that stopped the call or None).

    SIGTERM or SIGINT to this process (or to a run's sa-train) stops the call: each sa-train
    running writes the checkpoint of its step (train/training/interruption.py), no further run
    starts, and the same command continues."""
    maps = {network.name: maps_folder(work, network) for network in RECIPE}
    deadline = time.monotonic() + 60.0 * minutes
    threads = str(max(1, (os.cpu_count() or 1) // max(1, parallel)))
    record = {}
    waiting = {network.name for network in RECIPE}  # runs whose turn in this call is not over
    stop = StopRequest()  # taken while the runs train
    stopped_by = []  # the signal that stopped a run's sa-train, once one has

    def steps_left(network):
        reached = newest_step(run_folder(work, network) / "checkpoints")
        return max(0, total_steps(network, size) - reached)

    def train(network):
        allowance = time_share(deadline - time.monotonic(), parallel, steps_left(network),
                               sum(steps_left(n) for n in RECIPE if n.name in waiting))
        start = time.monotonic()
        run = run_folder(work, network)
        run.parent.mkdir(parents=True, exist_ok=True)
        timing = run.with_suffix(".seconds")
        before = float(timing.read_text()) if timing.is_file() else 0.0

        def record_seconds() -> float:
            # Written every minute, so that a call killed by SIGKILL keeps its time too.
            seconds = before + time.monotonic() - start
            with atomic_path(timing) as tmp:
                tmp.write_text(f"{seconds:.1f}")
            return seconds

        if steps_left(network) and allowance > 0 and not stop.requested and not stopped_by:
            log = run.with_suffix(".log")
            command = train_command(work, network, maps[network.name], size, device)
            with open(log, "a") as output:
                process = subprocess.Popen(command, stdout=output, stderr=subprocess.STDOUT,
                                           env=os.environ | {"OMP_NUM_THREADS": threads})
                end, recorded = start + allowance, start
                while (process.poll() is None and time.monotonic() < end
                       and not stop.requested):
                    try:
                        process.wait(timeout=1.0)
                    except subprocess.TimeoutExpired:
                        if time.monotonic() - recorded >= 60.0:
                            recorded = time.monotonic()
                            record_seconds()
                if process.poll() is None:
                    process.terminate()  # sa-train writes the checkpoint of its step and
                    process.wait()  # exits (a second signal, as after Ctrl-C, is ignored)
                elif process.returncode - 128 in SIGNALS:
                    stopped_by.append(process.returncode - 128)  # signalled, checkpoint kept
                elif process.returncode:
                    raise InputError(log, f"sa-train failed (exit status {process.returncode})")
        seconds = record_seconds()
        record[network.name] = {"steps": newest_step(run / "checkpoints"),
                                "of_steps": total_steps(network, size),
                                "seconds": round(seconds, 1)}
        waiting.discard(network.name)
        click.echo(json.dumps({"run": network.name, **record[network.name]}))

    with stop, ThreadPoolExecutor(max(1, parallel)) as pool:
        list(pool.map(train, RECIPE))
    return record, stop.signal_number or (stopped_by[0] if stopped_by else None)


def time_share(seconds_left: float, parallel: int, steps_left: int,
               steps_left_waiting: int) -> float:
    """Seconds a run may train: of the ``seconds_left`` (times ``parallel``, the runs trained at
    once), the share its steps left are of those of every run whose turn in this call is not
    over (``steps_left_waiting``, its own included), and never past the deadline."""
    share = seconds_left * parallel * steps_left / max(1, steps_left_waiting)
    return min(share, seconds_left)


def export(work: Path, network: Network, size_name: str, command: str) -> Path:
    """files/svbrdf-<network>.safetensors from the run's newest checkpoint (written again only
    when the run has a newer one)."""
    path = exported_file(work, network)
    newest = checkpoint_files(run_folder(work, network) / "checkpoints")
    if not newest:
        raise InputError(run_folder(work, network), "no checkpoint to export: give the "
                                                    "training more minutes")
    if path.is_file() and model_metadata(path, FORMAT, "model").get(
            "trained_from") == newest[-1].name:
        return path
    net = load_network(newest[-1])
    path.parent.mkdir(parents=True, exist_ok=True)
    save_model(net, path, {
        "class": network.name, "trained_from": newest[-1].name,
        "command": command,
        "recipe": json.dumps(dataclasses.asdict(network)),
        "steps": f"{checkpoint_step(newest[-1])} of {total_steps(network, SIZES[size_name])}"})
    return path


def exported_file(work: Path, network: Network) -> Path:
    """work/files/svbrdf-<network>.safetensors: the export of one run (the file its --class
    choice estimates with, among the release's files)."""
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
        training_probe_folder(work, shared)
        make_sets(work, size, parallel)
        record, stopped_by = train_runs(work, size, device, train_minutes, parallel)
        if stopped_by:
            write_card(work, command, record, None)
            click.echo(f"release.py: stopped by {signal.Signals(stopped_by).name}: each run "
                       f"keeps the checkpoint of its step, the same command continues", err=True)
            raise SystemExit(128 + stopped_by)
        for network in RECIPE:
            export(work, network, size_name, command)
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
