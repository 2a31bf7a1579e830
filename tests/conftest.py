"""Shared fixtures: Mitsuba, small synthetic inputs written to temporary folders, shared data."""

import json
import subprocess
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from render.common.images import write_exr

REPO = Path(__file__).resolve().parent.parent
SHARED_DATA = REPO.parent / "shared" / "data"
BUNDLED_PROBES = REPO / "probes"
BUNDLED_MATERIALS = REPO / "scenes" / "materials"

needs_shared = pytest.mark.skipif(not SHARED_DATA.is_dir(),
                                  reason="../shared/data is not present on this machine")


@pytest.fixture(scope="session")
def mi():
    from render.mitsuba_reference.loading import load_mitsuba

    return load_mitsuba("llvm_ad_rgb")


@pytest.fixture(scope="session")
def renderer(mi):
    from render.mitsuba_reference.scene import PlanarSampleRenderer

    return PlanarSampleRenderer("llvm_ad_rgb", spp=256)


def signal_once(command: list[str], ready: Callable[[], bool], signal_number: int,
                delay: float = 0.0) -> tuple[int, str, bool]:
    """Run ``command`` from the repository root and send it ``signal_number`` once ``ready()``
    holds, ``delay`` seconds later; returns its exit status, its stderr and whether it was still
    running when signalled."""
    with tempfile.TemporaryFile("w+") as stderr:  # a file: a full pipe would block the run
        process = subprocess.Popen(command, cwd=REPO, stdout=subprocess.DEVNULL, stderr=stderr)
        while process.poll() is None and not ready():
            time.sleep(0.005)
        time.sleep(delay)
        signalled = process.poll() is None
        process.send_signal(signal_number)
        process.wait()
        stderr.seek(0)
        return process.returncode, stderr.read(), signalled


def write_png(path, pixels):
    """Write float pixels in [0, 1], (H, W) or (H, W, 3), as an 8-bit PNG."""
    Image.fromarray(np.round(np.clip(pixels, 0, 1) * 255).astype(np.uint8)).save(path)


def make_probe(path, radiance):
    write_exr(path, np.asarray(radiance, np.float32))
    return Path(path)


def make_material(folder, albedo, **maps):
    """A material folder with ``<name>_albedo.png`` and any ``<name>_<suffix>.png`` maps."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    write_png(folder / "m_albedo.png", albedo)
    for suffix, pixels in maps.items():
        write_png(folder / f"m_{suffix}.png", pixels)
    return folder


BUNDLED_PHOTO = REPO / "scenes" / "photos" / "brick-reference-01.jpg"


def estimate_bundled_photo(out, *options):
    """Run ``sa-estimate`` on the bundled photo into ``out`` with ``options``; returns its
    JSON report line and material.json as dicts."""
    from click.testing import CliRunner

    from train.cli.sa_estimate import main as sa_estimate
    result = CliRunner().invoke(sa_estimate, [str(BUNDLED_PHOTO), *options, "--out", str(out)])
    assert result.exit_code == 0, result.output
    report = json.loads(result.stdout.strip().splitlines()[-1])
    return report, json.loads((Path(out) / BUNDLED_PHOTO.stem / "material.json").read_text())
