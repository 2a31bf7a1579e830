"""Try: the plastic network's joint reading head fit again on real sets, fold by fold.

On the real-set validation (scripts/real_validation.py) the specular lobe carries most of the
relit error. The joint reading head (train.fits.joint_reading: a small MLP that corrects the
specular albedo and roughness from the networks' readings and the photo's statistics) is the
cheapest part that reads the lobe. For each validation fold, a fresh head is fit on photos of
the real sets of the other three folds (each set's own specular pair, under the training
probes: every shared probe but the 8 held out), and the plastic file with it is measured on the
fold's validation photos (the same photos as the shipped files'), as the choice
``plastic+real-head``.

    .venv/bin/python experiments/joint_reading_on_real_sets.py --out OUT [--photos 2400]
"""

import sys
from pathlib import Path

import click

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "scripts"))
from real_validation import (FOLDS, SHARED, TEST_PROBES, VALIDATION_PROBES,  # noqa: E402
                             evaluate_choice, linked_folder, report_beside_shipped)

from train.estimation.network_choice import FixedNetwork  # noqa: E402
from train.fits.joint_reading import FitConfig, fit  # noqa: E402
from train.fits.part_fitting import fit_part_onto_model  # noqa: E402
from train.networks.model_files import load_network, shipped_model_path  # noqa: E402

NAME = "plastic+real-head"


@click.command()
@click.option("--out", required=True, type=click.Path())
@click.option("--photos", default=2400, show_default=True)
@click.option("--relights", default=2, show_default=True)
@click.option("--steps", default=10000, show_default=True)
@click.option("--samples", default=60, show_default=True)
def main(out, photos, relights, steps, samples):
    out = Path(out)
    held_out = set(VALIDATION_PROBES + TEST_PROBES)
    training_probes = linked_folder(
        out / "probes-training", sorted(p.name for p in (SHARED / "probes").glob("*.exr")
                                        if p.stem not in held_out), SHARED / "probes")

    def refit(fold):
        """The plastic file with a head fit on the other folds' sets (fit once, kept)."""
        model = out / "fits" / fold / "svbrdf-plastic.safetensors"
        if not model.is_file():
            others = [s for other, names in FOLDS.items() if other != fold for s in names]
            maps = linked_folder(out / "fits" / fold / "maps", others, SHARED / "svbrdfs")
            cfg = FitConfig(work=str(out / "fits" / fold / "work"), maps=str(maps),
                            photos=photos, relights=relights, mix_specular=False, steps=steps)
            report = fit_part_onto_model(
                shipped_model_path("plastic"), model, "joint_reading", training_probes,
                lambda net, bank: fit(cfg, net, bank),
                f"experiments/joint_reading_on_real_sets.py ({fold} left out)")
            click.echo(f"{fold}: {report}")
        return FixedNetwork(load_network(model))

    evaluate_choice(out, "validation", NAME, refit, samples)
    report_beside_shipped(out, [NAME])


if __name__ == "__main__":
    main()
