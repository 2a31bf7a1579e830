"""Test error with and without self-augmentation: same data, schedule and seed (docs/training.md).

    .venv/bin/python scripts/self_augmentation_experiment.py --shared ../shared/data --out EXP

Protocol (one material class, wood, as the paper trains one network per class):
1. ``make-materials --class wood`` makes LABELED + TEST + UNLABELED sets.
2. ``render-dataset`` renders the first LABELED + TEST sets under the shared probes, holding
   out TEST sets and a fifth of the probes for testing: the labeled dataset.
3. ``render-dataset`` renders the other UNLABELED sets: their images are the unlabeled
   photos (the labels are never read).
4. ``sa-train`` twice from the same seed with the same schedule: without unlabeled data (the
   baseline) and with it (self-augmentation).
Prints the test errors of both runs, at the last epoch and averaged over the last five (the
errors move from epoch to epoch), as JSON, and writes them to EXP/results.json.
"""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import click

BIN = Path(sys.executable).parent
ERRORS = ("albedo_mse", "normal_angle_deg", "log_specular_mse", "log_roughness_mse", "relit_mse")
LAST_EPOCHS = 5


def command(name, *arguments):
    subprocess.run([str(BIN / name), *map(str, arguments)], check=True)


@click.command()
@click.option("--shared", required=True, type=click.Path(exists=True), help="../shared/data")
@click.option("--out", required=True, type=click.Path(), help="Experiment folder.")
@click.option("--labeled", default=8, show_default=True, help="Labeled training sets.")
@click.option("--test", "test_sets", default=8, show_default=True, help="Held-out test sets.")
@click.option("--unlabeled", default=24, show_default=True, help="Sets rendered as unlabeled.")
@click.option("--epochs", default=10, show_default=True, help="Epochs of each phase.")
@click.option("--seed", default=0, show_default=True)
def main(shared, out, labeled, test_sets, unlabeled, epochs, seed):
    out, probes = Path(out), Path(shared) / "probes"
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
    render = ["--resolution", 64, "--render-size", 128, "--rotations", 1, "--crops", 2,
              "--spp", 64, "--workers", 2, "--seed", seed]
    command("render-dataset", "--probes", probes, "--svbrdfs", out / "labeled-maps", "--out",
            out / "labeled", "--test-materials", test_sets / (labeled + test_sets),
            "--test-probes", 0.2, *render)
    command("render-dataset", "--probes", probes, "--svbrdfs", out / "unlabeled-maps", "--out",
            out / "unlabeled", "--test-materials", 0, "--test-probes", 0, *render)
    results = {}
    for run, extra in (("baseline", []), ("self-augmented", ["--unlabeled", out / "unlabeled"])):
        command("sa-train", "--dataset", out / "labeled", "--out", out / run, "--probes", probes,
                "--network", "small", "--labeled-epochs", epochs, "--self-augmented-epochs",
                epochs, "--seed", seed, "--log-every", 100, *extra)
        tests = json.loads((out / run / "history.json").read_text())["test"]
        last = tests[-LAST_EPOCHS:]
        results[run] = {"final": tests[-1],
                        f"mean_of_last_{LAST_EPOCHS}_epochs": {
                            name: sum(record[name] for record in last) / len(last)
                            for name in ERRORS}}
    (out / "results.json").write_text(json.dumps(results, indent=2) + "\n")
    print(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
