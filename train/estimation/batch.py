"""``sa-estimate``: the reduced SVBRDF of a batch of photos, written into an output folder.

Each photo is estimated by an Estimator (train.estimation.estimator: a shipped class network
or a given model file) and
written as train.estimation.outputs says: a folder per photo and ``report.html``. The
specular albedo and roughness come from the photo's centre square read at the network's input
size, the estimate that sa-evaluate measures. ``run`` returns a report per photo (the command
prints each as a JSON line): the network and the milliseconds it took (at input size; full
resolution).

A batch resumes (the project's rule, render.common.resume). The folder's options
(``OUT/config.json``: the model file's and probes' SHA-256, the class, ``max_side``) must be
those of the run that started it, or the run is refused naming the options that differ; the
list of photos may change. A photo's folder is written as ``OUT/.<stem>.partial`` and renamed
to ``OUT/<stem>`` when whole, with its report (``estimate.json``, which also holds the photo
file's SHA-256): a folder under its final name is complete, and a re-run skips it (refusing a
photo whose file is not the one the folder was made from), redoing what a killed run left
half-written. ``overwrite`` estimates every photo again and records this run's options.
One run at a time writes into a folder (render.common.folder_lock). Every photo to estimate
is read and checked before anything is written; one photo's pixels are in memory at a time.
"""

import json
import shutil
from dataclasses import dataclass
from pathlib import Path

from tqdm import tqdm

from render.common.atomic_files import write_json
from render.common.errors import InputError, require_output_folder
from render.common.folder_lock import lock_folder
from render.common.package_data import BUNDLED_PROBES, installed_file
from render.common.probes import load_probe
from render.common.resume import continue_folder, file_digest
from render.torch_renderer.renderer import ProbeBank
from train.data.photos import read_linear_photo, read_photo
from train.estimation.estimator import Estimator
from train.estimation.outputs import write_photo_folder, write_report

DEFAULT_PROBES = tuple(str(installed_file(BUNDLED_PROBES, name)) for name in
                       ("park.exr", "env-studio.exr", "potsdamer_platz.exr"))
"""The bundled probes the estimates are relit under by default."""
MAY_CHANGE = ("photos",)
"""Options a resumed batch may change (render.common.resume): the photos (one may be added)."""
REPORT_FILE = "estimate.json"
"""A photo folder's report; the folder is complete when it is under its final name."""
PARTIAL, REPLACED = ".partial", ".replaced"
"""Suffixes of a photo folder being written (``.<stem>.partial``) and of one being replaced
under ``overwrite`` (``.<stem>.replaced``): a killed run's are removed by the next."""


@dataclass(frozen=True)
class EstimateConfig:
    photos: tuple
    """Photo files (PNG, JPEG, TIFF, BMP, EXR, HDR), read by train.data.photos.read_photo."""
    out: str
    """Output folder: a folder per photo and report.html."""
    probes: tuple = DEFAULT_PROBES
    """HDR probes of the relit images; the first one also lights the preview and the Mitsuba
    scene."""
    overwrite: bool = False
    """Estimate every photo again, replacing its folder, and record this run's options."""


def batch_options(cfg: EstimateConfig, estimator: Estimator) -> dict:
    """What a resumed batch must share with the run that started it (module docstring)."""
    return {"models": {Path(path).name: file_digest(path)
                       for path in estimator.choice.model_files},
            "class": estimator.material_class, "max_side": estimator.max_side,
            "probes": [[Path(path).name, file_digest(path)] for path in cfg.probes],
            "photos": [str(path) for path in cfg.photos]}


def finished_report(folder: Path, photo: str | Path) -> dict | None:
    """The report of ``folder`` if it is a finished estimate of ``photo``, None if it does not
    exist; an InputError if it holds another photo's estimate or no readable report."""
    if not folder.is_dir():
        return None
    try:
        report = json.loads((folder / REPORT_FILE).read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        raise InputError(folder, f"not a finished estimate ({error}); remove it or use "
                                 f"--overwrite") from None
    if report.get("photo_sha256") != file_digest(photo):
        raise InputError(photo, f"{folder} was estimated from another file of this name; use "
                                f"--overwrite or another --out")
    return report


def run(cfg: EstimateConfig, estimator: Estimator) -> list[dict]:
    """Estimate the reduced SVBRDF of each photo of ``cfg`` with ``estimator`` and write the
    outputs, continuing a cut-off batch; returns a report per photo (its output folder, the
    network, network milliseconds and parameters; a finished photo's as it was)."""
    out = require_output_folder(cfg.out)
    stems = [Path(path).stem for path in cfg.photos]
    if len(set(stems)) != len(stems):
        raise InputError(cfg.photos[0], "two photos share a file name stem (output folders)")
    probes = [load_probe(path) for path in cfg.probes]
    if len({Path(path).stem for path in cfg.probes}) != len(probes):
        raise InputError(cfg.probes[0], "two probes share a file name stem (relit-<stem>.png)")
    finished = {} if cfg.overwrite else {
        stem: report for path, stem in zip(cfg.photos, stems)
        if (report := finished_report(out / stem, path)) is not None}
    for path, stem in zip(cfg.photos, stems):  # checks every photo before anything is written
        if stem not in finished:
            read_photo(path, estimator.input_size)
    options = batch_options(cfg, estimator)
    lock_folder(out, "sa-estimate")
    if cfg.overwrite:
        (out / "config.json").unlink(missing_ok=True)
    continue_folder(out, options, MAY_CHANGE, "sa-estimate")
    remove_stale(out)
    bank = ProbeBank([probe.radiance for probe in probes])  # relit images render on the CPU
    reports, done = [], 0
    with tqdm(total=len(stems), initial=len(finished), desc="sa-estimate",
              unit="photo") as progress:
        for path, stem in zip(cfg.photos, stems):
            if stem in finished:
                reports.append(finished[stem])
                continue
            reports.append(estimate_photo(path, stem, out, estimator, probes, bank, cfg.probes))
            done += 1
            progress.set_postfix(done=done, skipped=len(finished),
                                 left=len(stems) - len(finished) - done)
            progress.update()
    write_report(out / "report.html", reports)
    return reports


def remove_stale(out: Path) -> None:
    """Remove what a killed run left in ``out``: photo folders being written or replaced, and
    temporary files and folders (render.common.atomic_files). The caller holds the lock, so
    none is a live run's."""
    for stale in [*out.glob(f".*{PARTIAL}"), *out.glob(f".*{REPLACED}"), *out.glob(".*.tmp*")]:
        if stale.is_dir():
            shutil.rmtree(stale)
        else:
            stale.unlink()


def estimate_photo(path: str | Path, stem: str, out: Path, estimator: Estimator, probes: list,
                   bank: ProbeBank, probe_paths: tuple) -> dict:
    """Estimate one photo into ``out/<stem>`` (written whole under a temporary name, then
    renamed; an earlier folder of that name is replaced); returns its report."""
    linear_photo = read_linear_photo(path)  # one whole photo in memory at a time
    result = estimator.estimate(linear_photo)
    folder, partial = out / stem, out / f".{stem}{PARTIAL}"
    relit = write_photo_folder(partial, result.svbrdf(stem), linear_photo,
                               {"photo": str(Path(path).resolve())} | result.network,
                               estimator.input_size, probes, bank, probe_paths)
    report = {"photo": str(path), "out": str(folder)} | result.network | {
        "network_ms": round(result.network_ms, 1),
        "full_resolution_ms": round(result.full_resolution_ms, 1),
        "map_size": [int(result.albedo.shape[1]), int(result.albedo.shape[0])],
        "relit": relit,
        "specular_albedo": result.specular_albedo.tolist(),
        "roughness": result.roughness,
        "photo_sha256": file_digest(path)}
    write_json(partial / REPORT_FILE, report)
    if folder.exists():  # overwrite: the old folder goes only once the new one is whole
        replaced = out / f".{stem}{REPLACED}"
        folder.rename(replaced)
        partial.rename(folder)
        shutil.rmtree(replaced)
    else:
        partial.rename(folder)
    return report
