"""Self-augmentation against the baseline, measured with ``sa-evaluate`` (docs/training.md).

    .venv/bin/python scripts/self_augmentation_experiment.py --sets WOOD_SETS/ \
        --probes TRAIN_PROBES/ --heldout HELDOUT_DATASET/ [--heldout ...] \
        --heldout-probes TEST_PROBES/ --out EXP [--labeled 4] [--pool 20] [--seeds 0,1,2] \
        [--pretrain-epochs 4] [--unlabeled-per-labeled 1]

One class, wood, as the paper compares. The material sets in ``--sets`` (sorted by name) are
split once: the first ``--pool`` may be labeled, the others are never labeled and give the
unlabeled photos. The held-out datasets (render-dataset folders of sets and probes never used
here) are what every network is judged on, against the naive baseline.

1. Unlabeled photos: ``render-dataset`` (Mitsuba) renders the never-labeled sets under
   ``--unlabeled-probes`` of the training probes, 64 px samples of 128 px renders (the scale
   of the labeled crops). Shared by all seeds.
2. Per seed, ``--labeled`` sets drawn from the pool by the seed, and three ``sa-train`` runs of
   the ``small`` network, the labeled minibatches rendered on the fly (``--labeled-maps``)
   under the training probes:
   - ``pretrained``: ``--pretrain-epochs`` labeled epochs (the paper starts self-augmentation
     from a network trained on labeled data);
   - ``baseline``: from ``pretrained``, ``--epochs`` more labeled epochs;
   - ``self-augmented``: from ``pretrained``, the same labeled minibatches, interleaved with
     ``--unlabeled-per-labeled`` self-augmented ones per labeled one (1, the paper's: one
     before each) made from the unlabeled photos (rendered under the training probes).
   Both arms start from the same weights with a fresh optimizer, see the same labeled
   minibatches (drawn from the seed and step) and differ only in the self-augmented ones.
3. ``sa-evaluate`` of each run on ``--samples`` of the held-out dataset, relit under the
   held-out probes.

Writes to EXP: results.json (every run's mean errors, the naive baseline's, and the ratios),
summary.md (per error: mean and spread over seeds of each run's ratio to naive, and the change
with self-augmentation per seed) and ratios.png, rewritten after every seed. Re-running the
command reuses what is finished: every command it runs resumes or is skipped when done.
"""

import json
import subprocess
import sys
from pathlib import Path

import click
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

BIN = Path(sys.executable).parent
ERRORS = ("relit_rmse", "albedo_rmse", "normal_angle_deg", "log_specular_error",
          "log_roughness_error")
RUNS = ("pretrained", "baseline", "self-augmented")


def command(name, *arguments, stdout=None):
    subprocess.run([str(BIN / name), *map(str, arguments)], check=True, stdout=stdout)


def link_folders(folders, out):
    """A folder ``out`` of symbolic links to ``folders``."""
    out.mkdir(parents=True, exist_ok=True)
    for folder in folders:
        link = out / folder.name
        if not link.exists():
            link.symlink_to(folder.resolve())
    return out


def unlabeled_photos(sets, probes, count, out):
    """render-dataset of ``sets`` under ``count`` evenly spaced ``probes``: the unlabeled
    photos (their labels are never read)."""
    files = sorted(p for p in probes.iterdir() if p.suffix.lower() in (".exr", ".hdr"))
    chosen = [files[i] for i in np.linspace(0, len(files) - 1, count).round().astype(int)]
    command("render-dataset", "--probes", link_folders(chosen, out / "unlabeled-probes"),
            "--svbrdfs", link_folders(sets, out / "unlabeled-maps"), "--out", out / "unlabeled",
            "--resolution", 64, "--render-size", 128, "--rotations", 1, "--crops", 2,
            "--spp", 64, "--workers", 2, "--test-materials", 0, "--test-probes", 0)
    return out / "unlabeled"


def train_runs(labeled_maps, unlabeled, probes, out, seed, pretrain_epochs, epochs,
               epoch_samples, unlabeled_per_labeled):
    """The three runs of one seed (see the module docstring); returns {run: run folder}."""
    common = ["--labeled-maps", labeled_maps, "--render-size", 128, "--epoch-samples",
              epoch_samples, "--network", "small", "--probes", probes, "--seed", seed,
              "--log-every", 100]
    folders = {run: out / run for run in RUNS}
    command("sa-train", *common, "--out", folders["pretrained"], "--labeled-epochs",
            pretrain_epochs, "--self-augmented-epochs", 0)
    for run, extra in (("baseline", []),
                       ("self-augmented", ["--unlabeled", unlabeled, "--unlabeled-per-labeled",
                                           unlabeled_per_labeled])):
        command("sa-train", *common, "--out", folders[run], "--init-from", folders["pretrained"],
                "--labeled-epochs", 0, "--self-augmented-epochs", epochs, *extra)
    return folders


def evaluate(run, heldout, heldout_probes, samples, out):
    """sa-evaluate's mean errors of ``run`` on the datasets ``heldout`` (skipped when
    already evaluated)."""
    results = out / "results.json"
    if not results.exists():
        datasets = [option for folder in heldout for option in ("--dataset", folder)]
        with open(out.with_suffix(".json"), "w") as stdout:
            command("sa-evaluate", "--model", run, *datasets, "--split", "all",
                    "--probes", heldout_probes, "--samples", samples, "--out", out,
                    stdout=stdout)
    return json.loads(results.read_text())["mean"]


def write_summary(path, results):
    """Markdown: per error, each run's ratio to naive (mean and standard deviation over the
    seeds), and the change of the error with self-augmentation per seed."""
    seeds = sorted(results)
    lines = ["| error | naive | " + " | ".join(f"{run} / naive" for run in RUNS)
             + " | self-augmented vs baseline, per seed | seeds lower |",
             "| --- | --- | " + " | ".join("---" for _ in RUNS) + " | --- | --- |"]
    for name in ERRORS:
        naive = np.mean([results[s]["baseline"]["naive"][name] for s in seeds])
        cells = []
        for run in RUNS:
            ratios = [results[s][run]["ratio"][name] for s in seeds]
            cells.append(f"{np.mean(ratios):.3f} ± {np.std(ratios):.3f}")
        changes = [100 * (results[s]["self-augmented"]["model"][name]
                          / results[s]["baseline"]["model"][name] - 1) for s in seeds]
        lines.append(f"| {name} | {naive:.4g} | " + " | ".join(cells) + " | "
                     + ", ".join(f"{c:+.1f}%" for c in changes)
                     + f" | {sum(c < 0 for c in changes)} of {len(changes)} |")
    path.write_text("\n".join(lines) + "\n")


def plot_ratios(path, results):
    """Each run's error / naive per error, a dot per seed and a bar for the mean."""
    seeds = sorted(results)
    figure, axis = plt.subplots(figsize=(10, 4))
    width = 0.8 / len(RUNS)
    for offset, run in enumerate(RUNS):
        x = np.arange(len(ERRORS)) + (offset - (len(RUNS) - 1) / 2) * width
        ratios = np.array([[results[s][run]["ratio"][name] for name in ERRORS] for s in seeds])
        axis.bar(x, ratios.mean(0), width, label=run, alpha=0.7)
        for row in ratios:
            axis.plot(x, row, "k.", markersize=4)
    axis.axhline(1.0, color="k", linewidth=0.8, linestyle="--")
    axis.set_xticks(np.arange(len(ERRORS)), ERRORS)
    axis.set_ylabel("error / naive baseline's")
    axis.set_title(f"Held-out wood, {len(seeds)} seeds (dots); below 1: better than naive")
    axis.legend()
    figure.tight_layout()
    figure.savefig(path, dpi=100)
    plt.close(figure)


@click.command()
@click.option("--sets", required=True, type=click.Path(exists=True, file_okay=False),
              help="Wood material folders (make-materials --class wood).")
@click.option("--probes", required=True, type=click.Path(exists=True, file_okay=False),
              help="Training probes.")
@click.option("--heldout", required=True, multiple=True,
              type=click.Path(exists=True, file_okay=False),
              help="render-dataset folder of held-out sets under held-out probes (repeatable).")
@click.option("--heldout-probes", required=True, type=click.Path(exists=True, file_okay=False),
              help="Held-out probes, for relighting.")
@click.option("--out", required=True, type=click.Path(), help="Experiment folder.")
@click.option("--labeled", default=4, show_default=True, help="Labeled sets per seed.")
@click.option("--pool", default=20, show_default=True,
              help="The first POOL sets may be labeled; the others give unlabeled photos.")
@click.option("--unlabeled-probes", default=10, show_default=True,
              help="Training probes the unlabeled photos are rendered under.")
@click.option("--unlabeled-from", type=click.Path(exists=True, file_okay=False), default=None,
              help="Another experiment folder whose unlabeled photos to use (made with the "
                   "same --sets, --pool and --unlabeled-probes) instead of rendering them.")
@click.option("--pretrain-epochs", default=4, show_default=True)
@click.option("--epochs", default=3, show_default=True, help="Epochs of both arms.")
@click.option("--unlabeled-per-labeled", default=1.0, show_default=True,
              help="Self-augmented minibatches per labeled one in the self-augmented arm.")
@click.option("--epoch-samples", default=1200, show_default=True)
@click.option("--samples", default=48, show_default=True, help="Held-out samples evaluated.")
@click.option("--seeds", default="0,1,2", show_default=True, help="Comma-separated seeds.")
def main(sets, probes, heldout, heldout_probes, out, labeled, pool, unlabeled_probes,
         unlabeled_from, pretrain_epochs, epochs, unlabeled_per_labeled, epoch_samples,
         samples, seeds):
    out, probes = Path(out), Path(probes)
    folders = sorted(p for p in Path(sets).iterdir() if p.is_dir())
    if len(folders) <= pool or labeled > pool:
        raise click.UsageError(f"{sets} holds {len(folders)} sets: need more than --pool "
                               f"{pool} and --labeled {labeled} at most --pool")
    if unlabeled_from:
        unlabeled = Path(unlabeled_from) / "unlabeled"
        if not unlabeled.is_dir() or not any(unlabeled.iterdir()):
            raise click.UsageError(f"{unlabeled_from}: no unlabeled photos in it (expected "
                                   "the unlabeled/ folder of another experiment)")
    else:
        unlabeled = unlabeled_photos(folders[pool:], probes, unlabeled_probes, out)
    results = {}
    for seed in (int(s) for s in seeds.split(",")):
        chosen = np.random.default_rng(seed).choice(pool, labeled, replace=False)
        seed_out = out / f"seed-{seed}"
        labeled_maps = link_folders([folders[i] for i in sorted(chosen)],
                                    seed_out / "labeled-maps")
        runs = train_runs(labeled_maps, unlabeled, probes, seed_out, seed, pretrain_epochs,
                          epochs, epoch_samples, unlabeled_per_labeled)
        results[seed] = {run: evaluate(folder, heldout, heldout_probes, samples,
                                       seed_out / f"eval-{run}")
                         for run, folder in runs.items()}
        (out / "results.json").write_text(json.dumps(results, indent=2) + "\n")
        write_summary(out / "summary.md", results)
        plot_ratios(out / "ratios.png", results)
    print((out / "summary.md").read_text())


if __name__ == "__main__":
    main()
