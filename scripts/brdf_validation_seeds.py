"""Summarize sa-validate runs of several seeds: per labeled set, the mean and spread of the test
render MSE without and with self-augmentation, and the per-seed ratio with/without. Writes a
Markdown table (stdout and OUT.md) and a figure (OUT.png): every seed's error per labeled set,
without and with self-augmentation, on a log scale.

    python scripts/brdf_validation_seeds.py OUT SEED_FOLDER...

Each SEED_FOLDER is an ``sa-validate --out`` folder (its results.json and config.json).
"""

import json
from pathlib import Path

import click
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from render.common.atomic_files import atomic_path  # noqa: E402
from train.brdf_validation.validation import PAPER_MSE, PATTERNS  # noqa: E402


def _spread(values):
    """'mean ± standard deviation' of positive values, in scientific notation."""
    return f"{np.mean(values):.2e} ± {np.std(values, ddof=1):.1e}"


@click.command()
@click.argument("out", type=click.Path())
@click.argument("folders", nargs=-1, required=True, type=click.Path(exists=True))
def main(out, folders):
    runs = [json.loads((Path(f) / "results.json").read_text()) for f in folders]
    seeds = [json.loads((Path(f) / "config.json").read_text())["seed"] for f in folders]
    patterns = ["dense", *(p for p in PATTERNS if p in runs[0])]
    lines = [f"| labeled set | labeled BRDFs | render MSE, mean ± sd over seeds {seeds} | "
             "with SA | with SA / without, per seed | paper | paper with SA |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for pattern in patterns:
        without = [r[pattern]["render_mse"] for r in runs]
        key = f"{pattern} SA"
        with_sa = [r[key]["render_mse"] for r in runs] if key in runs[0] else None
        paper = PAPER_MSE.get(pattern, (None, None))
        lines.append("| " + " | ".join([
            pattern, str(runs[0][pattern]["labeled"]), _spread(without),
            _spread(with_sa) if with_sa else "",
            ", ".join(f"{w / o:.2f}" for w, o in zip(with_sa, without)) if with_sa else "",
            f"{paper[0]}" if paper[0] else "", f"{paper[1]}" if paper[1] else ""]) + " |")
    table = "\n".join(lines) + "\n"
    click.echo(table)
    with atomic_path(Path(f"{out}.md")) as tmp:
        tmp.write_text(table)

    figure, axes = plt.subplots(figsize=(8, 4))
    for column, (suffix, color, label) in enumerate(
            (("", "tab:gray", "without SA"), (" SA", "tab:blue", "with SA"))):
        present = [(x, p + suffix) for x, p in enumerate(patterns) if p + suffix in runs[0]]
        for x, key in present:
            values = [r[key]["render_mse"] for r in runs]
            axes.scatter(np.full(len(values), x + 0.15 * (2 * column - 1)), values, color=color,
                         label=label if key == present[0][1] else None, s=18)
    axes.set_xticks(range(len(patterns)), patterns)
    axes.set_yscale("log")
    axes.set_ylabel("test render MSE")
    axes.set_title(f"sa-validate, seeds {seeds}: each dot one seed")
    axes.legend()
    figure.tight_layout()
    with atomic_path(Path(f"{out}.png")) as tmp:
        figure.savefig(tmp, format="png", dpi=110)


if __name__ == "__main__":
    main()
