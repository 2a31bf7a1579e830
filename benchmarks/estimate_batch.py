"""Benchmark of ``sa-estimate`` batches: peak memory and time per photo against the number of
photos, and the time a re-run of a finished batch takes (every photo skipped).

For each count of ``--counts``, a batch of that many photos of mixed sizes (the k-th photo's
longer side is SIDES[k % len(SIDES)], up to 4,000 px: every batch holds every size) is
estimated by ``sa-estimate`` in a child process, whose peak resident memory (the kernel's
``ru_maxrss`` of the children of a wrapper process, so one batch's figure is its own) and wall
time are measured. The photos are JPEG crops of the bundled brick photo enlarged to each size,
one file per size, linked under a name per photo (one output folder each). Prints JSON: per
count, peak MiB, seconds, seconds per photo, and the re-run's seconds.

    python benchmarks/estimate_batch.py [--counts 100,1000] [--max-side 512] [--work DIR]
"""

import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import click
from PIL import Image

REPO = Path(__file__).resolve().parent.parent
PHOTO = REPO / "scenes" / "photos" / "brick-reference-01.jpg"
SIDES = (4000, 256, 1024, 512, 2048, 768, 3000, 384)
"""Longer sides (px) of the batch's photos, in turn; the shorter side is 3/4 of it."""
PEAK_OF_CHILD = ("import resource, subprocess, sys; "
                 "code = subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL).returncode; "
                 "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss); "
                 "sys.exit(code)")
"""A wrapper that runs a command and prints its peak resident memory (KiB, Linux)."""


def size_files(folder: Path) -> dict[int, Path]:
    """One JPEG per side of SIDES: the bundled photo resized to side x 3/4 side."""
    files = {}
    with Image.open(PHOTO) as photo:
        photo = photo.convert("RGB")
        for side in SIDES:
            path = folder / f"size-{side}.jpg"
            photo.resize((side, side * 3 // 4), Image.Resampling.BICUBIC).save(path, quality=90)
            files[side] = path
    return files


def batch(folder: Path, files: dict[int, Path], count: int) -> list[Path]:
    """``count`` photo names in ``folder``, each a link to the file of its side."""
    folder.mkdir(parents=True, exist_ok=True)
    photos = []
    for k in range(count):
        path = folder / f"photo-{k:05d}.jpg"
        if not path.exists():
            path.symlink_to(files[SIDES[k % len(SIDES)]])
        photos.append(path)
    return photos


def measured(command: list[str]) -> tuple[float, float]:
    """(peak resident MiB, wall seconds) of ``command`` run to its end."""
    start = time.perf_counter()
    result = subprocess.run([sys.executable, "-c", PEAK_OF_CHILD, *command], cwd=REPO,
                            capture_output=True, text=True)
    seconds = time.perf_counter() - start
    if result.returncode != 0:
        raise SystemExit(f"sa-estimate failed: {result.stderr.strip().splitlines()[-1]}")
    return int(result.stdout.strip().splitlines()[-1]) / 1024.0, seconds


@click.command()
@click.option("--counts", default="100,1000", show_default=True, help="Batch sizes.")
@click.option("--max-side", default=512, show_default=True,
              help="sa-estimate --max-side: the maps' longer side (the photos are decoded "
                   "whole whatever it is).")
@click.option("--work", type=click.Path(), default=None,
              help="Folder for the photos and outputs (default: a temporary one).")
def main(counts, max_side, work):
    with tempfile.TemporaryDirectory() as temporary:
        root = Path(work or temporary)
        root.mkdir(parents=True, exist_ok=True)
        files = size_files(root)
        results = []
        for count in [int(c) for c in counts.split(",")]:
            photos = batch(root / f"photos-{count}", files, count)
            command = [sys.executable, "-m", "train.cli.sa_estimate", *map(str, photos),
                       "--out", str(root / f"out-{count}"), "--max-side", str(max_side)]
            peak, seconds = measured(command)
            _, rerun = measured(command)
            results.append({"photos": count, "peak_mib": round(peak, 1),
                            "seconds": round(seconds, 1),
                            "seconds_per_photo": round(seconds / count, 3),
                            "rerun_seconds": round(rerun, 1)})
            print(json.dumps(results[-1]), file=sys.stderr, flush=True)
    print(json.dumps({"benchmark": "estimate_batch", "sides": SIDES, "max_side": max_side,
                      "machine": platform.machine(), "cpus": os.cpu_count(),
                      "results": results}, indent=1))


if __name__ == "__main__":
    main()
