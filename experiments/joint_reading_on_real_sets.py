"""Try: the plastic network's joint reading head fit again on real sets, fold by fold.

On the real-set validation (scripts/real_validation.py) the specular lobe carries most of the
relit error. The joint reading head (train.fits.joint_reading: a small MLP that corrects the
specular albedo and roughness from the networks' readings and the photo's statistics) is the
cheapest part that reads the lobe. For each validation fold, a fresh head is fit on photos of
the real sets of the other three folds (each set's own specular pair, under the training
probes: every shared probe but the 8 held out), and the plastic file with it is measured on the
fold's validation photos (the same photos as the shipped files'), as the choice
``plastic+real-head``.

``--mix-specular`` pairs each real set's maps with the specular pair of another set drawn at
random (train.data.map_samples), so that 18 sets give 18 x 18 looks instead of 18, and
``--procedural FOLDER`` adds the material folders of FOLDER (for instance a few make-materials
plastics and metals) to every fold's sets: the choice ``plastic+real-head-mixed``.

    .venv/bin/python experiments/joint_reading_on_real_sets.py --out OUT [--photos 2400] \
        [--mix-specular] [--procedural FOLDER]
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



@click.command()
@click.option("--out", required=True, type=click.Path())
@click.option("--photos", default=2400, show_default=True)
@click.option("--relights", default=2, show_default=True)
@click.option("--steps", default=10000, show_default=True)
@click.option("--samples", default=60, show_default=True)
@click.option("--mix-specular", is_flag=True, help="Photos of mixed specular pairs.")
@click.option("--procedural", type=click.Path(exists=True, file_okay=False), default=None,
              help="Folder of material folders added to every fold's sets.")
def main(out, photos, relights, steps, samples, mix_specular, procedural):
    out = Path(out)
    name = "plastic+real-head-mixed" if mix_specular or procedural else "plastic+real-head"
    held_out = set(VALIDATION_PROBES + TEST_PROBES)
    training_probes = linked_folder(
        out / "probes-training", sorted(p.name for p in (SHARED / "probes").glob("*.exr")
                                        if p.stem not in held_out), SHARED / "probes")

    def refit(fold):
        """The plastic file with a head fit on the other folds' sets (fit once, kept)."""
        folder = out / "fits" / name / fold
        model = folder / "svbrdf-plastic.safetensors"
        if not model.is_file():
            others = [s for other, names in FOLDS.items() if other != fold for s in names]
            maps = linked_folder(folder / "maps", others, SHARED / "svbrdfs")
            if procedural:
                linked_folder(maps, sorted(p.name for p in Path(procedural).iterdir()
                                           if p.is_dir()), Path(procedural))
            cfg = FitConfig(work=str(folder / "work"), maps=str(maps), photos=photos,
                            relights=relights, mix_specular=mix_specular, steps=steps)
            report = fit_part_onto_model(
                shipped_model_path("plastic"), model, "joint_reading", training_probes,
                lambda net, bank: fit(cfg, net, bank),
                f"experiments/joint_reading_on_real_sets.py ({fold} left out, "
                f"mix_specular {mix_specular}, procedural {procedural is not None})")
            click.echo(f"{fold}: {report}")
        return FixedNetwork(load_network(model))

    evaluate_choice(out, "validation", name, refit, samples)
    report_beside_shipped(out, [name])


if __name__ == "__main__":
    main()
