"""Try: the default estimate's map networks fine-tuned on procedural relief as deep as the real
sets', measured on the real-set validation.

The procedural sets' relief is about 1 degree from flat, the real sets' 12 to 17 for bricks,
grass and fabric (docs/experiments/2026-12-05-plastic-lobe-on-real-folds.md), and the shipped
plastic network's normals are flat (about 0.1 degree) even on its own training sets. Here the
shipped plastic file's ``--networks`` (its normal network, by default on the normals' own loss
alone, as the paper trains each network) are fine-tuned by sa-train on the release's
procedural plastic sets (``--release-work``: a scripts/release.py work folder, its
maps/plastic and probes-training) with every crop's relief scaled by a factor drawn
log-uniformly from 1 to ``--relief-scale`` (sa-train --relief-scale), the lobe reader frozen;
then the default estimate (``--class unknown``: the file's maps with the fixed lobe) is
measured on the real-set validation beside the shipped default, on the same photos, and how
the normal network reads procedural relief (mean angle from flat of its estimate and of the
truth, and its error against the flat baseline's, on 12 crops of the training sets at relief
times 1 and 16) is printed.

    .venv/bin/python experiments/relief_scale.py --out OUT --release-work WORK \
        [--relief-scale 16] [--steps 1200]
"""

import subprocess
import sys
from pathlib import Path

import click
import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "scripts"))
from real_validation import evaluate_choice, report_beside_shipped  # noqa: E402

from render.common.exposure import expose  # noqa: E402
from render.common.probes import find_probes, load_probe  # noqa: E402
from render.torch_renderer.renderer import ProbeBank, render  # noqa: E402
from train.data.map_samples import MapSampler  # noqa: E402
from train.estimation.network_choice import FixedNetwork, network_choice  # noqa: E402
from train.networks.model_files import load_network, save_model, shipped_model_path  # noqa: E402
from train.networks.svbrdf_net import SVBRDFNet  # noqa: E402

BIN = Path(sys.executable).parent
DIAGNOSTIC_SETS = 20
"""Training sets the relief reading is measured on (every 20th of the folder)."""


def degrees_between(a: torch.Tensor, b: torch.Tensor) -> float:
    """Mean angle in degrees between two (B, 3, S, S) unit normal maps."""
    return float(torch.rad2deg(torch.acos((a * b).sum(1).clamp(-1.0, 1.0))).mean())


def relief_reading(net: SVBRDFNet, maps: Path, probes: Path, diagnostic: Path) -> list[dict]:
    """How ``net`` reads procedural relief: for 12 crops of DIAGNOSTIC_SETS sets of ``maps``
    with their relief times 1 and 16 (a height field's amplitude: every normal's slopes),
    rendered under the training probes, the mean angles from flat of the truth and of the
    estimate, and the estimate's and the flat baseline's error."""
    names = sorted(p.name for p in maps.iterdir())
    for name in names[::max(1, len(names) // DIAGNOSTIC_SETS)]:
        if not (diagnostic / name).exists():
            diagnostic.mkdir(parents=True, exist_ok=True)
            (diagnostic / name).symlink_to((maps / name).resolve())
    files = find_probes(probes)
    bank = ProbeBank([load_probe(path).radiance for path in files])
    sampler = MapSampler(diagnostic, bank, list(range(len(files))), net.config.input_size, 512)
    batch = sampler.batch(np.random.default_rng(0), 12)
    probe_index = torch.as_tensor([p["probe_index"] for p in batch["provenance"]])
    rotation = torch.as_tensor([p["rotation_deg"] for p in batch["provenance"]])
    flat = torch.zeros_like(batch["normal"])
    flat[:, 2] = 1.0
    rows = []
    for gain in (1.0, 16.0):
        normal = batch["normal"].clone()
        normal[:, :2] *= gain
        normal = normal / normal.norm(dim=1, keepdim=True)
        image = expose(render(batch["albedo"], normal, torch.exp(batch["log_specular"]),
                              torch.exp(batch["log_roughness"][:, 0]), bank, probe_index,
                              rotation))
        with torch.no_grad():
            estimate = net(image, ("normal",))["normal"]
        rows.append({"relief_gain": gain, "truth_from_flat": degrees_between(normal, flat),
                     "estimate_from_flat": degrees_between(estimate, flat),
                     "estimate_error": degrees_between(estimate, normal),
                     "flat_error": degrees_between(flat, normal)})
    return rows


@click.command()
@click.option("--out", required=True, type=click.Path(),
              help="Output folder (resumable); scripts/real_validation.py's layout.")
@click.option("--release-work", required=True, type=click.Path(exists=True, file_okay=False),
              help="A scripts/release.py work folder (its maps/plastic, probes-training).")
@click.option("--relief-scale", default=16.0, show_default=True)
@click.option("--steps", default=1200, show_default=True, help="Multiple of 200.")
@click.option("--networks", default="normal", show_default=True,
              help="sa-train --train-networks (of albedo, normal).")
@click.option("--relit-loss-weight", default=0.0, show_default=True,
              help="sa-train --relit-loss-weight (0: each network on its own labels' loss).")
def main(out, release_work, relief_scale, steps, networks, relit_loss_weight):
    out, work = Path(out), Path(release_work)
    name = (f"unknown+relief{relief_scale:g}-{networks.replace(',', '+')}"
            f"-relit{relit_loss_weight:g}")
    model = out / "files" / name / "svbrdf-plastic.safetensors"
    if not model.is_file():
        run = out / "runs" / name
        subprocess.run([str(BIN / "sa-train"),
                        "--init-from", str(shipped_model_path("plastic")),
                        "--train-networks", networks, "--mix-specular",
                        "--relief-scale", str(relief_scale),
                        "--labeled-maps", str(work / "maps" / "plastic"),
                        "--probes", str(work / "probes-training"), "--out", str(run),
                        "--network", "compact", "--albedo-network", "photo-affine",
                        "--relit-loss-weight", str(relit_loss_weight),
                        "--labeled-epochs", str(steps // 200),
                        "--self-augmented-epochs", "0", "--learning-rate", "0.0005",
                        "--lr-gamma", "1e-3", "--epoch-samples", "3200", "--batch-size", "16",
                        "--render-size", "512", "--checkpoint-every", "100",
                        "--log-every", "25"], check=True)
        save_model(load_network(run), model, {
            "class": "plastic", "recipe": f"experiments/relief_scale.py --relief-scale "
                                          f"{relief_scale:g} --steps {steps} --networks "
                                          f"{networks} --relit-loss-weight "
                                          f"{relit_loss_weight:g}"})
    for label, path in (("shipped", shipped_model_path("plastic")), (name, model)):
        for row in relief_reading(load_network(path), work / "maps" / "plastic",
                                  work / "probes-training", out / "relief-reading-sets"):
            print(label, {k: round(v, 2) for k, v in row.items()}, flush=True)
    evaluate_choice(out, "validation", "unknown", lambda fold: network_choice(None, "unknown"))
    evaluate_choice(out, "validation", name,
                    lambda fold: FixedNetwork(load_network(model), fixed_lobe=True))
    report_beside_shipped(out, [name])


if __name__ == "__main__":
    main()
