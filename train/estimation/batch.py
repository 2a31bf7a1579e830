"""``sa-estimate``: the reduced SVBRDF of a batch of photos, written into an output folder.

Each photo is estimated by an Estimator (train.estimation.estimator: a shipped network chosen
per photo by the material classifier, a shipped class network, or a given model file) and
written as train.estimation.outputs says: a folder per photo and ``report.html``. The
specular albedo and roughness come from the photo's centre square read at the network's input
size, the estimate that sa-evaluate measures. Every photo is read and checked before anything
is written; an existing output folder is refused. ``run`` returns a report per photo (the
command prints each as a JSON line): the network chosen and the milliseconds it took (at
input size, the classifier's choice included; full resolution).
"""

from dataclasses import dataclass
from pathlib import Path

from render.common.errors import InputError, require_output_folder
from render.common.package_data import BUNDLED_PROBES, installed_file
from render.common.probes import load_probe
from render.torch_renderer.renderer import ProbeBank
from train.data.photos import read_linear_photo, read_photo
from train.estimation.estimator import Estimator
from train.estimation.outputs import write_photo_folder, write_report

DEFAULT_PROBES = tuple(str(installed_file(BUNDLED_PROBES, name)) for name in
                       ("park.exr", "env-studio.exr", "potsdamer_platz.exr"))
"""The bundled probes the estimates are relit under by default."""


@dataclass(frozen=True)
class EstimateConfig:
    photos: tuple
    """Photo files (PNG, JPEG, TIFF, BMP, EXR, HDR), read by train.data.photos.read_photo."""
    out: str
    """Output folder: a folder per photo and report.html."""
    probes: tuple = DEFAULT_PROBES
    """HDR probes of the relit images; the first one also lights the preview and the Mitsuba
    scene."""


def run(cfg: EstimateConfig, estimator: Estimator) -> list[dict]:
    """Estimate the reduced SVBRDF of each photo of ``cfg`` with ``estimator`` and write the
    outputs; returns a report per photo (its output folder, the network and why, network
    milliseconds and parameters)."""
    require_output_folder(cfg.out)
    size = estimator.input_size
    for path in cfg.photos:  # checks every photo before anything is written
        read_photo(path, size)
    stems = [Path(path).stem for path in cfg.photos]
    if len(set(stems)) != len(stems):
        raise InputError(cfg.photos[0], "two photos share a file name stem (output folders)")
    probes = [load_probe(path) for path in cfg.probes]
    if len({Path(path).stem for path in cfg.probes}) != len(probes):
        raise InputError(cfg.probes[0], "two probes share a file name stem (relit-<stem>.png)")
    bank = ProbeBank([probe.radiance for probe in probes])  # relit images render on the CPU
    reports = []
    for path, stem in zip(cfg.photos, stems):
        linear_photo = read_linear_photo(path)  # one whole photo in memory at a time
        result = estimator.estimate(linear_photo)
        folder = Path(cfg.out) / stem
        relit = write_photo_folder(folder, result.svbrdf(stem), linear_photo,
                                   {"photo": str(Path(path).resolve())} | result.network, size,
                                   probes, bank, cfg.probes)
        reports.append({"photo": str(path), "out": str(folder)} | result.network | {
                        "network_ms": round(result.network_ms, 1),
                        "full_resolution_ms": round(result.full_resolution_ms, 1),
                        "map_size": [int(result.albedo.shape[1]), int(result.albedo.shape[0])],
                        "relit": relit,
                        "specular_albedo": result.specular_albedo.tolist(),
                        "roughness": result.roughness})
    write_report(Path(cfg.out) / "report.html", reports)
    return reports
