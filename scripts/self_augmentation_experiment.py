"""Test error with and without self-augmentation: same data, schedule and seed (docs/training.md).

    .venv/bin/python scripts/self_augmentation_experiment.py --shared ../shared/data --out EXP \
        [--seeds 0,1,2] [--epochs 10] [--crops 2] [--train-on K --subsets N]

Protocol per seed (one material class, wood, as the paper trains one network per class):
1. ``make-materials --class wood`` makes LABELED + TEST + UNLABELED sets.
2. ``render-dataset`` renders the first LABELED + TEST sets under the shared probes, holding
   out TEST sets and a fifth of the probes for testing: the labeled dataset.
3. ``render-dataset`` renders the other UNLABELED sets: their images are the unlabeled
   photos (the labels are never read).
4. ``sa-train`` twice from the same seed with the same schedule: without unlabeled data (the
   baseline) and with it (self-augmentation).
The seed draws the wood sets, the splits, the initialization and the minibatches. With
``--train-on K`` each data seed gives ``--subsets`` replicates, each training on a random K of
the labeled sets (the same test sets and unlabeled photos) from its own training seed: the
paper's claim is that self-augmentation helps most when labeled data is scarce. Writes to
EXP: results.json (every run's test history; per replicate and error, the final error and its
mean over the last five epochs), summary.md (the relative changes and their mean over the
replicates) and curves.png (test errors over the epochs, baseline against self-augmented, per
replicate), all three rewritten after every replicate. Re-running the command reuses what is
finished (every command it runs resumes).
"""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import click
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

BIN = Path(sys.executable).parent
ERRORS = ("albedo_mse", "normal_angle_deg", "log_specular_mse", "log_roughness_mse", "relit_mse")
RUNS = ("baseline", "self-augmented")
LAST_EPOCHS = 5


def command(name, *arguments):
    subprocess.run([str(BIN / name), *map(str, arguments)], check=True)


def render_data(out, probes, labeled, test_sets, unlabeled, crops, seed):
    """The labeled and unlabeled dataset folders of one data seed."""
    maps = out / "maps"
    command("make-materials", "--class", "wood", "--count", labeled + test_sets + unlabeled,
            "--resolution", 256, "--seed", seed, "--out", maps)
    folders = sorted(p for p in maps.iterdir() if p.is_dir())
    for name, chosen in (("labeled-maps", folders[:labeled + test_sets]),
                         ("unlabeled-maps", folders[labeled + test_sets:])):
        (out / name).mkdir(exist_ok=True)
        for folder in chosen:
            if not (out / name / folder.name).exists():
                shutil.copytree(folder, out / name / folder.name)
    render = ["--resolution", 64, "--render-size", 128, "--rotations", 1, "--crops", crops,
              "--spp", 64, "--workers", 2, "--seed", seed]
    command("render-dataset", "--probes", probes, "--svbrdfs", out / "labeled-maps", "--out",
            out / "labeled", "--test-materials", test_sets / (labeled + test_sets),
            "--test-probes", 0.2, *render)
    command("render-dataset", "--probes", probes, "--svbrdfs", out / "unlabeled-maps", "--out",
            out / "unlabeled", "--test-materials", 0, "--test-probes", 0, *render)
    return out / "labeled", out / "unlabeled"


def subset_dataset(dataset, out, count, rng):
    """A dataset folder at ``out`` with ``count`` of ``dataset``'s training materials (drawn
    by ``rng``) and the first crop of each test render (a quarter of the test samples with
    four crops: the evaluation after every epoch dominates the time of such short runs); it
    lists the original sample files (linked)."""
    index = json.loads((dataset / "index.json").read_text())
    materials = sorted({s["material"] for s in index["samples"] if s["split"] == "train"})
    kept = set(rng.choice(materials, count, replace=False).tolist())
    samples = [s for s in index["samples"] if (s["split"] == "train" and s["material"] in kept)
               or (s["split"] == "test" and s["id"].endswith("_c00"))]
    out.mkdir(parents=True, exist_ok=True)
    if not (out / "samples").exists():
        (out / "samples").symlink_to((dataset / "samples").resolve())
    subset = {**index, "count": len(samples), "samples": samples, "labeled_materials":
              sorted(kept), "splits": {split: sum(s["split"] == split for s in samples)
                                       for split in ("train", "test")}}
    (out / "index.json").write_text(json.dumps(subset, indent=2) + "\n")
    return out


def train_pair(dataset, unlabeled, out, probes, epochs, seed):
    """The baseline and the self-augmented run on ``dataset``; returns {run: test history}."""
    histories = {}
    for run, extra in zip(RUNS, ([], ["--unlabeled", unlabeled])):
        command("sa-train", "--dataset", dataset, "--out", out / run, "--probes", probes,
                "--network", "small", "--labeled-epochs", epochs, "--self-augmented-epochs",
                epochs, "--seed", seed, "--log-every", 100, *extra)
        histories[run] = json.loads((out / run / "history.json").read_text())["test"]
    return histories


def summarize(histories):
    """Per error: final and last-five-epoch-mean errors of each run."""
    return {run: {"final": {name: tests[-1][name] for name in ERRORS},
                  f"mean_of_last_{LAST_EPOCHS}_epochs": {
                      name: float(np.mean([r[name] for r in tests[-LAST_EPOCHS:]]))
                      for name in ERRORS}}
            for run, tests in histories.items()}


def write_summary(path, results):
    """Markdown: per error and measure, the change with self-augmentation per replicate, its
    mean, and in how many replicates the error fell."""
    lines = ["| error | measure | change per replicate | mean change | replicates lower |",
             "| --- | --- | --- | --- | --- |"]
    for name in ERRORS:
        for measure in ("final", f"mean_of_last_{LAST_EPOCHS}_epochs"):
            changes = [100 * (r["summary"]["self-augmented"][measure][name]
                              / r["summary"]["baseline"][measure][name] - 1)
                       for r in results.values()]
            lines.append(f"| {name} | {measure.replace('_', ' ')} | "
                         + ", ".join(f"{c:+.1f}%" for c in changes)
                         + f" | {np.mean(changes):+.1f}% | {sum(c < 0 for c in changes)} of "
                           f"{len(changes)} |")
    path.write_text("\n".join(lines) + "\n")


def plot_curves(path, results):
    figure, axes = plt.subplots(1, len(ERRORS), figsize=(4 * len(ERRORS), 3.6))
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for color, (name, result) in zip(colors, results.items()):
        for run, style in zip(RUNS, ("--", "-")):
            tests = result["histories"][run]
            for axis, error in zip(axes, ERRORS):
                axis.plot([r["epoch"] for r in tests], [r[error] for r in tests], style,
                          color=color, label=f"{name} {run}")
    for axis, name in zip(axes, ERRORS):
        axis.set(title=name, xlabel="epoch", yscale="log")
    axes[0].legend(fontsize=7)
    figure.suptitle("Test errors: baseline (dashed) and self-augmented (solid), same replicate")
    figure.tight_layout()
    figure.savefig(path, dpi=90)
    plt.close(figure)


@click.command()
@click.option("--shared", required=True, type=click.Path(exists=True), help="../shared/data")
@click.option("--out", required=True, type=click.Path(), help="Experiment folder.")
@click.option("--labeled", default=8, show_default=True, help="Labeled training sets.")
@click.option("--test", "test_sets", default=8, show_default=True, help="Held-out test sets.")
@click.option("--unlabeled", default=24, show_default=True, help="Sets rendered as unlabeled.")
@click.option("--epochs", default=10, show_default=True, help="Epochs of each phase.")
@click.option("--crops", default=2, show_default=True, help="64 px samples per 128 px render.")
@click.option("--seeds", default="0,1,2", show_default=True,
              help="Comma-separated data seeds (wood sets, splits, renders).")
@click.option("--train-on", type=int, default=None,
              help="Train on this many of the labeled sets only, a random subset per replicate.")
@click.option("--subsets", default=1, show_default=True,
              help="With --train-on: replicates per data seed (subset and training seed).")
def main(shared, out, labeled, test_sets, unlabeled, epochs, crops, seeds, train_on, subsets):
    out, probes = Path(out), Path(shared) / "probes"
    results = {}
    for seed in (int(s) for s in seeds.split(",")):
        dataset, unlabeled_dataset = render_data(out / f"seed-{seed}", probes, labeled,
                                                 test_sets, unlabeled, crops, seed)
        for subset in range(subsets if train_on else 1):
            name = f"seed-{seed}" if train_on is None else f"seed-{seed}-subset-{subset}"
            training_set = dataset if train_on is None else subset_dataset(
                dataset, out / name / "labeled-subset", train_on,
                np.random.default_rng([seed, subset]))
            histories = train_pair(training_set, unlabeled_dataset, out / name, probes, epochs,
                                   seed if train_on is None else subset)
            results[name] = {"histories": histories, "summary": summarize(histories)}
            (out / "results.json").write_text(json.dumps(results, indent=2) + "\n")
            write_summary(out / "summary.md", results)  # after every replicate: usable if stopped
            plot_curves(out / "curves.png", results)
    print((out / "summary.md").read_text())


if __name__ == "__main__":
    main()
