"""Try: networks of the plastic file (by default its lobe reader, the homogeneous network)
fine-tuned with real sets, fold by fold.

On the real-set validation most of the naive baseline's relit error is on metals (about 60% of
it, docs/experiments/2026-12-05-fitted-heads-on-real-validation.md), where the plastic network's
lobe is no better than the baseline's (its procedural training never showed a metal). For each
validation fold of scripts/real_validation.py, the shipped plastic file's ``--networks`` are
fine-tuned by sa-train with the relit loss on procedural plastic and metal sets and the real sets
of the other three folds (each real set linked ``--real-copies`` times, so that a minibatch holds
some), each with its own specular pair, under the training probes; then measured on the fold's
validation photos (the same photos as the shipped files'), beside the shipped plastic file.
With ``--dielectrics-only`` the training sees no metal: no procedural metal sets, and no real
set whose relative specular albedo exceeds METAL_RELATIVE_SPECULAR (a metal's, whose reduced
diffuse albedo is the floor). ``--networks albedo,normal --relit-partners estimate`` fine-tunes
the map networks instead, each relit beside the frozen lobe reader's own estimate: the real
sets' albedos and relief, which procedural sets lack.

    .venv/bin/python experiments/plastic_on_real_folds.py --out OUT [--steps 800] \
        [--folds fold1,fold2,fold3,fold4] [--networks homogeneous] [--relit-partners truth]
"""

import subprocess
import sys
from pathlib import Path

import click

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "scripts"))
from real_validation import (  # noqa: E402
    FOLDS,
    SHARED,
    evaluate_choice,
    linked_folder,
    report_beside_shipped,
)
from release import training_probe_folder  # noqa: E402

from render.materials.reduced_svbrdf import load_material  # noqa: E402
from train.estimation.network_choice import network_choice  # noqa: E402
from train.networks.model_files import load_network, save_model, shipped_model_path  # noqa: E402
from train.training.trainer import RELIT_PARTNERS  # noqa: E402

BIN = Path(sys.executable).parent
PROCEDURAL = {"plastic": (0, 2, 3, 4), "metal": (0, 2)}
"""make-materials seeds (50 sets each) of the procedural sets beside the real ones."""
METAL_RELATIVE_SPECULAR = 2.0
"""Mean relative specular albedo above which a real set counts as a metal (the real sets'
metals: 4 to 39; their dielectrics: at most 1.2)."""


def is_metal(name: str) -> bool:
    """Whether the real set ``name`` reduces to a metal's lobe."""
    svbrdf = load_material(SHARED / "svbrdfs" / name)
    return float(svbrdf.specular.mean()) * 0.5 / float(svbrdf.albedo.mean()) \
        > METAL_RELATIVE_SPECULAR


def fold_maps(out: Path, fold: str, copies: int, dielectrics_only: bool) -> Path:
    """out/maps/<fold>[-dielectrics]: the procedural sets and ``copies`` links to each real set
    of the other folds (``dielectrics_only``: no metals)."""
    folder = out / "maps" / (f"{fold}-dielectrics" if dielectrics_only else fold)
    procedural = {c: seeds for c, seeds in PROCEDURAL.items()
                  if not (dielectrics_only and c == "metal")}
    for material_class, seeds in procedural.items():
        for seed in seeds:
            sets = out / "sets" / f"{material_class}-{seed}"
            if not sets.is_dir():
                subprocess.run([str(BIN / "make-materials"), "--class", material_class,
                                "--count", "50", "--seed", str(seed), "--resolution", "512",
                                "--out", str(sets)], check=True, stdout=subprocess.DEVNULL)
            linked_folder(folder, [p.name for p in sorted(sets.iterdir()) if p.is_dir()], sets)
    for other, names in FOLDS.items():
        for name in names if other != fold else ():
            if dielectrics_only and is_metal(name):
                continue
            for copy in range(copies):
                link = folder / f"{name}-{copy}"
                if not link.exists():
                    link.symlink_to((SHARED / "svbrdfs" / name).resolve())
    return folder


@click.command()
@click.option("--out", required=True, type=click.Path())
@click.option("--steps", default=800, show_default=True, help="Multiple of 200.")
@click.option("--real-copies", default=6, show_default=True)
@click.option("--folds", default=",".join(FOLDS), show_default=True)
@click.option("--dielectrics-only", is_flag=True, help="Train on no metal (module docstring).")
@click.option("--networks", default="homogeneous", show_default=True,
              help="sa-train --train-networks.")
@click.option("--relit-partners", type=click.Choice(RELIT_PARTNERS), default="truth",
              show_default=True, help="sa-train --relit-partners.")
def main(out, steps, real_copies, folds, dielectrics_only, networks, relit_partners):
    out = Path(out)
    probes = training_probe_folder(out, SHARED)
    name = ("plastic+real-" + ("lobe" if networks == "homogeneous" else networks.replace(",", "+"))
            + ("-dielectrics" if dielectrics_only else ""))
    folds = tuple(folds.split(","))
    for fold in folds:
        model = out / "files" / name / fold / "svbrdf-plastic.safetensors"
        if not model.is_file():
            run = out / "runs" / name / fold
            subprocess.run([str(BIN / "sa-train"),
                            "--init-from", str(shipped_model_path("plastic")),
                            "--train-networks", networks, "--own-specular",
                            "--relit-partners", relit_partners,
                            "--labeled-maps", str(fold_maps(out, fold, real_copies,
                                                            dielectrics_only)),
                            "--probes", str(probes), "--out", str(run), "--network", "compact",
                            "--albedo-network", "photo-affine", "--relit-loss-weight", "300",
                            "--labeled-epochs", str(steps // 200), "--self-augmented-epochs", "0",
                            "--learning-rate", "0.0005", "--lr-gamma", "1e-3",
                            "--epoch-samples", "3200", "--checkpoint-every", "200",
                            "--log-every", "50"], check=True)
            save_model(load_network(run), model, {
                "class": "plastic", "recipe": f"experiments/plastic_on_real_folds.py "
                                              f"--steps {steps} --real-copies {real_copies} "
                                              f"--networks {networks} "
                                              f"--relit-partners {relit_partners}"
                                              + (" --dielectrics-only" if dielectrics_only
                                                 else "")})
    evaluate_choice(out, "validation", name, lambda fold: network_choice(
        out / "files" / name / fold / "svbrdf-plastic.safetensors", "plastic"), only=folds)
    report_beside_shipped(out, [name])


if __name__ == "__main__":
    main()
