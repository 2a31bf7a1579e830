"""Estimates of real material sets against the naive baseline: the real-set validation (and,
once per release, the real-set test) of models/README.md.

The 30 real sets of ``../shared/data/svbrdfs`` are split once, here, by material kind:
TEST_SETS (6 sets, reported once per release, never used to choose) and four validation FOLDS
of 6 sets each (every choice is made on them; a network trained on real sets leaves out the
fold it is validated on). The held-out probes are split the same way: VALIDATION_PROBES light
and relight the validation photos, TEST_PROBES the test photos; no network is trained under
either.

For each fold and each network choice (``--choices``: sa-evaluate's --class choices) it runs
sa-evaluate (train.evaluation.estimate_evaluation) on ``--samples`` photos rendered by the
torch renderer from the fold's sets, under the fold's probes: the same photos for every choice,
each with the naive baseline's errors beside the model's. Sets a model was trained on
(``--exclude``; none of the shipped files' sets) are left out of every fold. Writes into
``--out``:

    <fold>/<choice>/results.json, figure.png   sa-evaluate's own output (kept: a re-run
                                               continues where it stopped)
    table.md, table.json                       per fold and choice the ratios of means, model
                                               over naive (relit RMSE, albedo RMSE), and the
                                               worst set's relit ratio; per set the relit ratio
    per_set.png                                the relit ratio of every set by every choice

    .venv/bin/python scripts/real_validation.py --out OUT [--split validation|test] \
        [--choices unknown,wood,plastic,metal] [--samples 60] [--exclude SET,...]
"""

import json
import os
from pathlib import Path

import click
import numpy as np
from matplotlib.figure import Figure

from render.common.atomic_files import atomic_path
from train.estimation.network_choice import CLASSES, network_choice
from train.evaluation.estimate_evaluation import EvaluationConfig, run

SHARED = Path(__file__).resolve().parent.parent.parent / "shared" / "data"
TEST_SETS = ("ambientcg_Metal030", "nvidia-mdl_metal_diamond_pattern", "ambientcg_Rock053",
             "ambientcg_Tiles036", "polyhaven_rosewood_veneer1", "ambientcg_Ice002")
"""Real sets of the test: reported once per release, never used to choose."""
FOLDS = {
    "fold1": ("ambientcg_Metal007", "godot_aluminium", "ambientcg_Bricks075B", "godot_marble",
              "materialx_wood", "ambientcg_Grass001"),
    "fold2": ("ambientcg_Metal009", "nvidia-mdl_brushed_antique_copper", "ambientcg_Marble006",
              "godot_rock", "godot_texture_wood", "godot_cheese"),
    "fold3": ("ambientcg_Metal012", "ambientcg_Chainmail004", "ambientcg_Onyx003",
              "godot_texture_bricks", "materialx_brick", "godot_sand"),
    "fold4": ("ambientcg_Metal055A", "ambientcg_Rock020", "godot_texture_rock", "pbrone_bricks",
              "ambientcg_WoodFloor043", "polyhaven_fabric_pattern_07"),
}
"""The validation folds: each holds metal, stone or brick, and wood or another kind."""
VALIDATION_PROBES = ("brown_photostudio_02", "circus_arena", "kiara_1_dawn", "rainforest_trail")
TEST_PROBES = ("aristea_wreck_puresky", "dikhololo_night", "env-lab", "modern_buildings_2")


def linked_folder(folder, names, source):
    """``folder`` holding a symbolic link to each of ``names`` in ``source``."""
    folder.mkdir(parents=True, exist_ok=True)
    for name in names:
        link = folder / name
        if not link.exists():
            os.symlink((source / name).resolve(), link)
    return folder


def material_set(sample):
    """The set of a sample sa-evaluate renders from material folders: its name less its
    number ('godot_rock_007' -> 'godot_rock')."""
    return sample.rsplit("_", 1)[0]


def fold_rows(results):
    """Per set and over all: (model relit, naive relit, model albedo, naive albedo) sums and
    counts of an sa-evaluate results dict."""
    per_set = {}
    for record in results["per_sample"]:
        errors = [record[kind][name] for name in ("relit_rmse", "albedo_rmse")
                  for kind in ("model", "naive")]
        per_set.setdefault(material_set(record["sample"]), []).append(errors)
    return {name: np.mean(rows, axis=0) for name, rows in per_set.items()}, \
        np.mean([e for rows in per_set.values() for e in rows], axis=0)


def summarize(out, folds, choices):
    """table.json, table.md and per_set.png from the finished evaluations."""
    table = {"folds": {}, "sets": {}}
    every = {}  # choice -> per-sample error rows over every fold
    for fold in folds:
        for choice in choices:
            path = out / fold / choice / "results.json"
            if not path.is_file():
                continue
            results = json.loads(path.read_text())
            every.setdefault(choice, []).extend(results["per_sample"])
            sets, overall = fold_rows(results)
            worst = max(sets, key=lambda s: sets[s][0] / sets[s][1])
            table["folds"].setdefault(fold, {})[choice] = {
                "photos": results["samples"], "relit_ratio": overall[0] / overall[1],
                "albedo_ratio": overall[2] / overall[3], "worst_set": worst,
                "worst_relit_ratio": sets[worst][0] / sets[worst][1]}
            for name, row in sets.items():
                table["sets"].setdefault(name, {})[choice] = row[0] / row[1]
    for choice, records in every.items():
        sets, overall = fold_rows({"per_sample": records})
        worst = max(sets, key=lambda s: sets[s][0] / sets[s][1])
        table["folds"].setdefault("all", {})[choice] = {
            "photos": len(records), "relit_ratio": overall[0] / overall[1],
            "albedo_ratio": overall[2] / overall[3], "worst_set": worst,
            "worst_relit_ratio": sets[worst][0] / sets[worst][1]}
    with atomic_path(out / "table.json") as tmp:
        tmp.write_text(json.dumps(table, indent=1))
    lines = ["| fold | choice | photos | relit / naive | albedo / naive | worst set (relit) |",
             "| --- | --- | --- | --- | --- | --- |"]
    for fold, rows in table["folds"].items():
        for choice, row in rows.items():
            lines.append(f"| {fold} | {choice} | {row['photos']} | {row['relit_ratio']:.2f} | "
                         f"{row['albedo_ratio']:.2f} | {row['worst_set']} "
                         f"({row['worst_relit_ratio']:.2f}) |")
    lines += ["", "| set | " + " | ".join(choices) + " |",
              "| --- |" + " --- |" * len(choices)]
    for name, row in sorted(table["sets"].items()):
        lines.append(f"| {name} | " + " | ".join(
            f"{row[c]:.2f}" if c in row else "" for c in choices) + " |")
    with atomic_path(out / "table.md") as tmp:
        tmp.write_text("\n".join(lines) + "\n")
    names = sorted(table["sets"])
    if names:
        figure = Figure(figsize=(max(6.0, 0.45 * len(names)), 4.5))
        axis = figure.subplots()
        width = 0.8 / len(choices)
        for k, choice in enumerate(choices):
            values = [table["sets"][n].get(choice, np.nan) for n in names]
            axis.bar(np.arange(len(names)) + (k - (len(choices) - 1) / 2) * width, values,
                     width, label=choice)
        axis.axhline(1.0, color="black", linewidth=0.8, label="naive baseline")
        axis.set_xticks(range(len(names)), names, rotation=70, ha="right", fontsize=7)
        axis.set_yscale("log")
        axis.set_ylabel("relit RMSE / naive (log scale)")
        axis.legend(fontsize=7)
        figure.tight_layout()
        with atomic_path(out / "per_set.png") as tmp:
            figure.savefig(tmp, format="png", dpi=100)
    return table


def split_folds(split: str) -> dict[str, tuple[str, ...]]:
    """{fold: its sets} of ``split``: the validation folds, or the test as one fold."""
    return FOLDS if split == "validation" else {"test": TEST_SETS}


def split_probe_folder(out: Path, split: str, shared: Path = SHARED) -> Path:
    """out/probes-<split>: links to the probes that light and relight ``split``'s photos."""
    return linked_folder(out / f"probes-{split}",
                         [f"{probe}.exr" for probe in (VALIDATION_PROBES if split == "validation"
                                                       else TEST_PROBES)], shared / "probes")


def evaluate_choice(out: Path, split: str, name: str, make_choice, samples: int = 60,
                    relights: int = 3, excluded=(),
                    shared: Path = SHARED, only: tuple[str, ...] | None = None,
                    device: str = "cpu") -> None:
    """sa-evaluate the network choice ``make_choice(fold)`` gives (train.estimation.
    network_choice) on every fold of ``split`` (or those named in ``only``) whose
    ``out/<fold>/<name>/results.json`` is missing: photos of the fold's sets less ``excluded``,
    under the split's probes (the same photos for every choice), rendered and relit on the
    torch ``device`` (the choice's networks must be on it). Experiments (experiments/) measure
    their variants with it."""
    folds = {fold: names for fold, names in split_folds(split).items()
             if only is None or fold in only}
    probes = split_probe_folder(out, split, shared)
    for fold, names in folds.items():
        kept = [set_name for set_name in names if set_name not in excluded]
        target = out / fold / name
        if not kept or (target / "results.json").is_file():
            continue
        sets = linked_folder(out / "sets" / fold, kept, shared / "svbrdfs")
        cfg = EvaluationConfig(out=str(target), probes=str(probes), materials=str(sets),
                               samples=samples, relights=relights, device=device)
        report = run(cfg, make_choice(fold))
        print(json.dumps({"fold": fold, "choice": name,
                          "relit_ratio": report["mean"]["ratio"]["relit_rmse"]}), flush=True)


def report_beside_shipped(out: Path, names: list[str]) -> None:
    """Summarize the validation in ``out`` for the shipped choices evaluated there and the
    experiment's ``names``, and print the table."""
    shipped = [c for c in CLASSES
               if (out / "fold1" / c / "results.json").is_file()]
    summarize(out, list(FOLDS), shipped + names)
    print((out / "table.md").read_text())


@click.command()
@click.option("--out", required=True, type=click.Path(), help="Output folder (resumable).")
@click.option("--split", type=click.Choice(("validation", "test")), default="validation",
              show_default=True)
@click.option("--choices", default=",".join(CLASSES), show_default=True,
              help="Network choices, as sa-evaluate's --class.")
@click.option("--samples", default=60, show_default=True, help="Photos per fold.")
@click.option("--relights", default=3, show_default=True)
@click.option("--exclude", default="", help="Sets left out (those the evaluated networks were "
                                           "trained on; no shipped network trained on any).")
@click.option("--shared", default=str(SHARED), show_default=True, type=click.Path(),
              help="The shared data folder (svbrdfs/, probes/).")
def main(out, split, choices, samples, relights, exclude, shared):
    out, shared = Path(out), Path(shared)
    choices = [c for c in choices.split(",") if c]
    excluded = {name for name in exclude.split(",") if name}
    for choice in choices:
        evaluate_choice(out, split, choice, lambda fold, c=choice: network_choice(None, c),
                        samples, relights, excluded, shared)
    folds = split_folds(split)
    summarize(out, list(folds), choices)
    click.echo((out / "table.md").read_text())


if __name__ == "__main__":
    main()
