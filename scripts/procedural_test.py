"""The procedural larger test of the class networks (models/README.md, "the larger test"):
Mitsuba renders of procedural sets no network trained on, under held-out probes, each class
network's estimates against the naive baseline.

Held-out data, never used in training:
  - material sets: make-materials seed 1 (the release trains on seeds 0 and 2-8), ``base`` +
    ``more`` sets per class, and the real set materialx_wood (wood);
  - probes: the 8 of HELD_OUT_PAIRS (the release trains under the other shared probes).

The first ``base`` sets of a class are split into 4 groups (at size toy, 1); group g is rendered
with Mitsuba (render-dataset, 1 rotation, one crop of the training scale) under the probe pair
g, with the real sets; the next ``more`` sets likewise, ``more`` / 4 to a pair, without them.
sa-evaluate then estimates every render with the class's network and relights each estimate
under 3 other held-out probes (``--relights``). At size ``full`` (40 + 80 sets, 512 px renders,
128 spp) these are the renders and photos of the card's larger test: 240 photos a class, 248 for
wood.

Into ``--out``, each step kept where done (a re-run continues): ``sets/<class>/`` (make-materials),
``probes/`` (the pairs), ``groups/`` (links), ``renders/<group>/`` (render-dataset),
``<name>/<class>/`` (sa-evaluate of the models of ``--models``: results.json, figure.png).

    .venv/bin/python scripts/procedural_test.py --out WORK [--models models/] [--name shipped] \
        [--classes wood,plastic,metal] [--size full|toy]
"""

import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import click

from render.common.errors import InputError
from train.estimation.network_choice import class_model_file

sys.path.insert(0, str(Path(__file__).resolve().parent))
from real_validation import SHARED, linked_folder  # noqa: E402

BIN = Path(sys.executable).parent
"""The environment's commands (make-materials, render-dataset, sa-evaluate)."""
HELD_OUT_PAIRS = (("aristea_wreck_puresky", "brown_photostudio_02"),
                  ("circus_arena", "dikhololo_night"), ("env-lab", "kiara_1_dawn"),
                  ("modern_buildings_2", "rainforest_trail"))
"""The 8 held-out probes in pairs: group g of a class is rendered under pair g."""
REAL_SETS = {"wood": ("materialx_wood",)}
"""Real sets rendered into every group of a class."""
SEED = 1
"""make-materials seed of the test's sets (no release trains on it)."""


@dataclass(frozen=True)
class TestSize:
    pairs: int
    """Probe pairs of HELD_OUT_PAIRS used, the first ones: groups of sets per part."""
    base: int
    """Sets per class in the first groups (a multiple of ``pairs``)."""
    more: int
    """Further sets per class in as many more groups (a multiple of ``pairs``)."""
    set_resolution: int
    """Side (px) of the make-materials maps."""
    resolution: int
    """Side (px) of a render's crop: the network's input."""
    render_size: int
    """Side (px) of the Mitsuba render the crop is taken from."""
    spp: int
    relights: int


SIZES = {"full": TestSize(4, 40, 80, 512, 256, 512, 128, 3),
         "toy": TestSize(1, 2, 0, 64, 32, 64, 4, 1)}


def groups(size: TestSize) -> list[tuple[str, int, range, bool]]:
    """(group name, probe pair, indices of its sets, whether the real sets join it) of each
    render group of a class."""
    found = []
    for part, first, count in (("", 0, size.base), ("more-", size.base, size.more)):
        per_pair = count // size.pairs
        found += [(f"{part}{pair}", pair, range(first + pair * per_pair,
                                                first + (pair + 1) * per_pair), not part)
                  for pair in range(size.pairs) if per_pair]
    return found


def render_test(work: Path, size: TestSize, material_class: str, shared: Path) -> list[Path]:
    """Make the class's sets and render its groups (kept ones are skipped); returns the
    render-dataset folders."""
    sets = work / "sets" / material_class
    subprocess.run([str(BIN / "make-materials"), "--class", material_class,
                    "--count", str(size.base + size.more), "--seed", str(SEED),
                    "--resolution", str(size.set_resolution), "--out", str(sets)],
                   check=True, stdout=subprocess.DEVNULL)
    folders = []
    for name, pair, indices, with_real_sets in groups(size):
        probes = linked_folder(work / "probes" / f"pair{pair}",
                               [f"{p}.exr" for p in HELD_OUT_PAIRS[pair]], shared / "probes")
        group = work / "groups" / f"{material_class}-{name}"
        linked_folder(group, [f"{material_class}_s{SEED}_{i:04d}" for i in indices], sets)
        if with_real_sets:
            linked_folder(group, REAL_SETS.get(material_class, ()), shared / "svbrdfs")
        out = work / "renders" / group.name
        subprocess.run([str(BIN / "render-dataset"), "--probes", str(probes),
                        "--svbrdfs", str(group), "--out", str(out),
                        "--resolution", str(size.resolution),
                        "--render-size", str(size.render_size), "--rotations", "1",
                        "--crops", "1", "--spp", str(size.spp), "--test-materials", "0",
                        "--test-probes", "0"], check=True, stdout=subprocess.DEVNULL)
        folders.append(out)
    return folders


def evaluate_class(work: Path, size: TestSize, material_class: str, renders: list[Path],
                   models: Path | None, name: str, shared: Path, device: str) -> Path:
    """sa-evaluate of the class network of ``models`` (None: the shipped files) on the class's
    ``renders`` (render_test's folders); returns its results.json."""
    every_probe = linked_folder(work / "probes" / "all",
                                [f"{p}.exr" for pair in HELD_OUT_PAIRS for p in pair],
                                shared / "probes")
    out = work / name / material_class
    subprocess.run([str(BIN / "sa-evaluate"),
                    "--model", str(class_model_file(material_class, models)),
                    *[option for folder in renders for option in ("--dataset", str(folder))],
                    "--split", "all", "--probes", str(every_probe), "--samples", "100000",
                    "--relights", str(size.relights), "--device", device, "--out", str(out)],
                   check=True, stdout=subprocess.DEVNULL)
    return out / "results.json"


@click.command()
@click.option("--out", required=True, type=click.Path(), help="Work folder (resumable).")
@click.option("--models", type=click.Path(file_okay=False), default=None,
              help="Folder of svbrdf-<class>.safetensors files. Default: the shipped ones.")
@click.option("--name", default="shipped", show_default=True,
              help="Sub-folder of --out for these models' evaluations.")
@click.option("--classes", default="wood,plastic,metal", show_default=True)
@click.option("--size", "size_name", type=click.Choice(sorted(SIZES)), default="full",
              show_default=True)
@click.option("--device", default="cpu", show_default=True, help="torch device of sa-evaluate.")
@click.option("--shared", default=str(SHARED), show_default=True, type=click.Path(),
              help="The shared data folder (svbrdfs/, probes/).")
def main(out, models, name, classes, size_name, device, shared):
    try:
        work, size = Path(out), SIZES[size_name]
        for material_class in classes.split(","):
            renders = render_test(work, size, material_class, Path(shared))
            click.echo(evaluate_class(work, size, material_class, renders,
                                      Path(models) if models else None, name, Path(shared),
                                      device))
    except InputError as error:
        raise click.ClickException(str(error)) from None


if __name__ == "__main__":
    main()
