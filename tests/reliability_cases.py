"""The reliability matrices as data: the fault matrix (commands killed, or starved of disk;
run by ``tests/test_fault_matrix.py``) and the bad-input matrix (for every command line, each
argument's bad forms and the message the user must get; run by
``tests/test_bad_input_matrix.py``). ``docs/reliability.md`` is generated from them
(``python -m tests.reliability_cases`` rewrites it, and a test checks that it is current), so
the tests and the document cannot drift.

A bad-input case is (command, argument, bad form, argv builder, expected message fragment). The argv
builder takes the ``BadInputs`` of one temporary folder and returns the command's arguments;
every path a case makes bad is one of its attributes, and the test checks that the message
names it.
"""

import atexit
import functools
import shutil
import struct
import tempfile
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from PIL import Image

from tests.conftest import BUNDLED_MATERIALS, BUNDLED_PHOTO, BUNDLED_PROBES, REPO, make_material, \
    make_probe, write_png

DOC = REPO / "docs" / "reliability.md"


@dataclass(frozen=True)
class BadInputs:
    """Bad files and folders, made once in ``root``."""
    root: Path

    def __getattr__(self, name):
        return self.root / FILES[name]


FILES = {
    "missing": "nowhere", "text_file": "notes.txt", "empty": "empty",
    "nan_probe": "probes-nan/nan.exr", "nan_probes": "probes-nan",
    "truncated_probe": "probes-truncated/cut.exr", "truncated_probes": "probes-truncated",
    "zero_probe": "probes-zero/zero.exr", "zero_probes": "probes-zero",
    "gray_probe": "probes-gray/gray.exr", "gray_probes": "probes-gray",
    "truncated_albedo": "materials-truncated/m/m_albedo.png",
    "truncated_materials": "materials-truncated",
    "photo_folder": "folder.png", "truncated_photo": "cut.png", "zero_photo": "zero.png",
    "nan_photo": "nan.exr", "good_photo": "good.png", "panorama_photo": "panorama.png",
    "thin_photo": "thin.png", "huge_photo": "huge.png", "foreign_model": "foreign.pt",
    "pickle_model": "payload.pt", "truncated_model": "cut.safetensors",
    "text_model": "notes.safetensors", "unlabeled_truncated": "unlabeled-truncated/cut.png",
    "corrupt_index": "dataset-corrupt/index.json",
}


def _png_header_only(width, height):
    """A PNG file declaring width x height 8-bit RGB pixels with no pixel data: what a photo
    too large to decode looks like before it is decoded."""
    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data)))

    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(b""))
            + chunk(b"IEND", b""))


def make_bad_inputs(root):
    """Write every bad input into ``root``; returns its BadInputs."""
    inputs = BadInputs(Path(root))
    inputs.text_file.write_text("not what was asked for\n")
    inputs.empty.mkdir()
    sky = np.ones((16, 32, 3), np.float32)
    make_probe(_parent(inputs.nan_probe), np.where(np.arange(16)[:, None, None] == 3,
                                                    np.nan, sky))
    probe_bytes = (BUNDLED_PROBES / "park.exr").read_bytes()
    _parent(inputs.truncated_probe).write_bytes(probe_bytes[:len(probe_bytes) // 2])
    _parent(inputs.zero_probe).write_bytes(b"")
    make_probe(_parent(inputs.gray_probe), sky[..., 0])
    folder = make_material(inputs.truncated_albedo.parent, np.full((8, 8, 3), 0.5))
    data = (folder / "m_albedo.png").read_bytes()
    (folder / "m_albedo.png").write_bytes(data[:len(data) // 2])
    inputs.photo_folder.mkdir()
    write_png(inputs.good_photo, np.random.default_rng(0).random((40, 40, 3)))
    photo = inputs.good_photo.read_bytes()
    inputs.truncated_photo.write_bytes(photo[:len(photo) // 3])
    inputs.zero_photo.write_bytes(b"")
    write_png(inputs.panorama_photo, np.full((16, 320, 3), 0.5))
    write_png(inputs.thin_photo, np.full((40, 1, 3), 0.5))
    inputs.huge_photo.write_bytes(_png_header_only(40_000, 30_000))
    _parent(inputs.corrupt_index).write_text('{"samples": [')
    _parent(inputs.unlabeled_truncated).write_bytes(photo[:len(photo) // 3])
    make_probe(inputs.nan_photo, np.where(np.arange(16)[:, None, None] == 3, np.nan,
                                          np.ones((16, 16, 3), np.float32)))
    torch.save({"weights": torch.ones(2)}, inputs.foreign_model)
    inputs.pickle_model.write_bytes(_pickle_payload(root))
    model = (REPO / "models" / "svbrdf-plastic.safetensors").read_bytes()
    inputs.truncated_model.write_bytes(model[:len(model) // 2])
    inputs.text_model.write_text("not a model\n")
    return inputs


def _parent(path):
    path.parent.mkdir(parents=True, exist_ok=True)
    return path


class _Payload:
    """A pickle whose loading would create a file (it must never be loaded)."""

    def __init__(self, marker):
        self.marker = str(marker)

    def __reduce__(self):
        return (open, (self.marker, "w"))


def _pickle_payload(root):
    import io
    import pickle
    buffer = io.BytesIO()
    pickle.dump({"format": "sa-svbrdf checkpoint 2", "model": _Payload(root / "PAYLOAD_RAN")},
                buffer)
    return buffer.getvalue()


def with_option(argv, option, value):
    """``argv`` with ``option``'s value replaced (or the option added)."""
    argv = list(argv)
    if option in argv:
        argv[argv.index(option) + 1] = str(value)
    else:
        argv += [option, str(value)]
    return argv


def render_dataset(i, out):
    return ["--probes", str(BUNDLED_PROBES), "--svbrdfs", str(BUNDLED_MATERIALS), "--out",
            str(out), "--resolution", "16", "--render-size", "32", "--rotations", "1",
            "--crops", "1", "--spp", "4"]


def make_materials(i, out):
    return ["--class", "wood", "--count", "1", "--resolution", "16", "--out", str(out)]


def check_renderer(i, out):
    return ["--probes", str(BUNDLED_PROBES), "--svbrdfs", str(BUNDLED_MATERIALS), "--size", "8",
            "--spp", "4", "--out", str(out)]


def sa_train(i, out):
    return ["--labeled-maps", str(BUNDLED_MATERIALS), "--probes", str(BUNDLED_PROBES), "--out",
            str(out), "--network", "small", "--input-size", "32", "--levels", "3",
            "--render-size", "64", "--epoch-samples", "16", "--batch-size", "8",
            "--labeled-epochs", "1", "--self-augmented-epochs", "0"]


def sa_estimate(i, out):
    return [str(i.good_photo), "--out", str(out)]


def sa_validate(i, out):
    return ["--probes", str(BUNDLED_PROBES), "--out", str(out), "--config", "toy", "--patterns",
            "2x2x2"]


def sa_evaluate(i, out):
    return ["--class", "plastic", "--materials", str(BUNDLED_MATERIALS), "--probes",
            str(BUNDLED_PROBES), "--out", str(out), "--samples", "1", "--relights", "1",
            "--sample-size", "32"]


def _probe_cases(base, option="--probes"):
    """A probes-folder argument's bad forms."""
    return [
        (option, "missing folder", lambda i, o: with_option(base(i, o), option, i.missing),
         "missing", "not found"),
        (option, "a file, not a folder", lambda i, o: with_option(base(i, o), option,
                                                                  i.text_file),
         "text_file", "is a file, not a folder"),
        (option, "empty folder", lambda i, o: with_option(base(i, o), option, i.empty),
         "empty", "no probes (.exr or .hdr files)"),
        (option, "probe with NaN", lambda i, o: with_option(base(i, o), option, i.nan_probes),
         "nan_probe", "NaN or Inf"),
        (option, "truncated probe", lambda i, o: with_option(base(i, o), option,
                                                             i.truncated_probes),
         "truncated_probe", "cannot read OpenEXR"),
        (option, "zero-size probe", lambda i, o: with_option(base(i, o), option,
                                                             i.zero_probes),
         "zero_probe", "empty file (0 bytes"),
        (option, "one-channel probe", lambda i, o: with_option(base(i, o), option,
                                                               i.gray_probes),
         "gray_probe", "grayscale probe"),
    ]


def _materials_cases(base, option):
    """A material-folders argument's bad forms."""
    return [
        (option, "missing folder", lambda i, o: with_option(base(i, o), option, i.missing),
         "missing", "not found"),
        (option, "a file, not a folder", lambda i, o: with_option(base(i, o), option,
                                                                  i.text_file),
         "text_file", "is a file, not a folder"),
        (option, "empty folder", lambda i, o: with_option(base(i, o), option, i.empty),
         "empty", "no material sub-folders"),
        (option, "a folder of probes", lambda i, o: with_option(base(i, o), option,
                                                                BUNDLED_PROBES),
         None, "no material sub-folders"),
        (option, "truncated albedo map", lambda i, o: with_option(base(i, o), option,
                                                                  i.truncated_materials),
         "truncated_albedo", "cannot decode image"),
    ]


def _out_cases(base):
    return [("--out", "a file, not a folder",
             lambda i, o: with_option(base(i, o), "--out", i.text_file), "text_file",
             "not a folder")]


def _model_cases(base):
    return [
        ("--model", "missing file", lambda i, o: base(i, o) + ["--model", str(i.missing)],
         "missing", "not found"),
        ("--model", "a foreign checkpoint", lambda i, o: base(i, o) + ["--model",
                                                                      str(i.foreign_model)],
         "foreign_model", "not an sa-svbrdf checkpoint"),
        ("--model", "a pickle with a code payload", lambda i, o: base(i, o) + [
            "--model", str(i.pickle_model)], "pickle_model", "cannot read checkpoint safely"),
        ("--model", "truncated safetensors", lambda i, o: base(i, o) + [
            "--model", str(i.truncated_model)], "truncated_model", "cannot read safetensors"),
        ("--model", "a text file named .safetensors", lambda i, o: base(i, o) + [
            "--model", str(i.text_model)], "text_model", "cannot read safetensors"),
    ]


def _class_case(base):
    return [("--class", "unknown class name", lambda i, o: with_option(base(i, o), "--class",
                                                                       "stone"),
             None, "'stone' is not one of")]


CASES = [
    *[("render-dataset", *case) for case in [
        *_probe_cases(render_dataset), *_materials_cases(render_dataset, "--svbrdfs"),
        *_out_cases(render_dataset)]],
    *[("make-materials", *case) for case in [
        *_class_case(make_materials),
        ("--augment", "missing folder", lambda i, o: make_materials(i, o) + [
            "--augment", str(i.missing)], "missing", "not found"),
        ("--augment", "empty folder", lambda i, o: make_materials(i, o) + [
            "--augment", str(i.empty)], "empty", "no material sub-folders"),
        ("--probe", "missing file", lambda i, o: make_materials(i, o) + [
            "--probe", str(i.missing)], "missing", "probe not found"),
        ("--probe", "probe with NaN", lambda i, o: make_materials(i, o) + [
            "--probe", str(i.nan_probe)], "nan_probe", "NaN or Inf"),
        ("--probe", "a folder, not a file", lambda i, o: make_materials(i, o) + [
            "--probe", str(i.empty)], "empty", "is a folder, not a file"),
        *_out_cases(make_materials)]],
    *[("check-renderer", *case) for case in [
        *_probe_cases(check_renderer)[:4], *_materials_cases(check_renderer, "--svbrdfs")[:3],
        ("--roughness", "outside the Ward range", lambda i, o: with_option(
            check_renderer(i, o), "--roughness", "0.001"), None, "must lie in [0.02, 1"),
        ("--roughness", "not numbers", lambda i, o: with_option(
            check_renderer(i, o), "--roughness", "rough"), None, "not a list of numbers"),
        ("--passes", "one pass (no spread) with --gradients", lambda i, o: check_renderer(
            i, o) + ["--gradients", "--passes", "1"], None, "1 is not in the range")]],
    *[("sa-train", *case) for case in [
        *_probe_cases(sa_train)[:4], *_materials_cases(sa_train, "--labeled-maps"),
        ("--dataset", "missing folder", lambda i, o: sa_train(i, o) + [
            "--dataset", str(i.missing)], "missing", "not found"),
        ("--dataset", "a folder without index.json", lambda i, o: sa_train(i, o) + [
            "--dataset", str(BUNDLED_PROBES)], None, "no index.json"),
        ("--dataset", "a corrupt index.json", lambda i, o: sa_train(i, o) + [
            "--dataset", str(i.corrupt_index.parent)], "corrupt_index",
         "cannot read the dataset index"),
        ("--unlabeled", "missing folder", lambda i, o: sa_train(i, o) + [
            "--unlabeled", str(i.missing)], "missing", "not found"),
        ("--unlabeled", "empty folder", lambda i, o: sa_train(i, o) + [
            "--unlabeled", str(i.empty)], "empty", "no unlabeled images"),
        ("--unlabeled", "a truncated photo", lambda i, o: sa_train(i, o) + [
            "--unlabeled", str(i.unlabeled_truncated.parent)], "unlabeled_truncated",
         "cannot decode image"),
        ("--init-from", "missing file", lambda i, o: sa_train(i, o) + [
            "--init-from", str(i.missing)], "missing", "not found"),
        ("--init-from", "a foreign checkpoint", lambda i, o: sa_train(i, o) + [
            "--init-from", str(i.foreign_model)], "foreign_model",
         "not an sa-svbrdf checkpoint"),
        ("--init-from", "truncated safetensors", lambda i, o: sa_train(i, o) + [
            "--init-from", str(i.truncated_model)], "truncated_model", "cannot read safetensors"),
        ("--crop-scales", "not whole numbers", lambda i, o: sa_train(i, o) + [
            "--crop-scales", "1,1.5"], None, "not a comma-separated list of whole numbers"),
        ("--crop-scales", "a crop larger than the render", lambda i, o: sa_train(i, o) + [
            "--crop-scales", "1,4"], None, "smaller than the largest crop"),
        ("--train-networks", "an unknown network", lambda i, o: sa_train(i, o) + [
            "--train-networks", "homogeneous,specular"], None, "name some of homogeneous"),
        *_out_cases(sa_train)]],
    *[("sa-estimate", *case) for case in [
        ("PHOTO", "missing file", lambda i, o: [str(i.missing), "--out", str(o)], "missing",
         "not found"),
        ("PHOTO", "a folder, not a file", lambda i, o: [str(i.photo_folder), "--out", str(o)],
         "photo_folder", "is a folder, not a file"),
        ("PHOTO", "truncated image", lambda i, o: [str(i.truncated_photo), "--out", str(o)],
         "truncated_photo", "cannot decode image"),
        ("PHOTO", "zero-size image", lambda i, o: [str(i.zero_photo), "--out", str(o)],
         "zero_photo", "empty file (0 bytes"),
        ("PHOTO", "NaN in an HDR photo", lambda i, o: [str(i.nan_photo), "--out", str(o)],
         "nan_photo", "NaN or infinite"),
        ("PHOTO", "a text file", lambda i, o: [str(i.text_file), "--out", str(o)],
         "text_file", "unsupported image format"),
        ("PHOTO", "a panorama, 20:1", lambda i, o: [str(i.panorama_photo), "--out", str(o)],
         "panorama_photo", "a side ratio of 20.0:1"),
        ("PHOTO", "1 pixel wide", lambda i, o: [str(i.thin_photo), "--out", str(o)],
         "thin_photo", "photo is 1x40 pixels"),
        ("PHOTO", "too large to decode (40,000 x 30,000)", lambda i, o: [
            str(i.huge_photo), "--out", str(o)], "huge_photo", "image is 40000x30000 pixels"),
        *_model_cases(sa_estimate), *_class_case(sa_estimate),
        ("--probe", "missing file", lambda i, o: sa_estimate(i, o) + [
            "--probe", str(i.missing)], "missing", "probe not found"),
        ("--probe", "probe with NaN", lambda i, o: sa_estimate(i, o) + [
            "--probe", str(i.nan_probe)], "nan_probe", "NaN or Inf"),
        *_out_cases(sa_estimate)]],
    *[("sa-validate", *case) for case in [*_probe_cases(sa_validate), *_out_cases(sa_validate)]],
    *[("sa-evaluate", *case) for case in [
        *_probe_cases(sa_evaluate)[:4], *_materials_cases(sa_evaluate, "--materials"),
        ("--dataset", "missing folder", lambda i, o: [
            "--class", "plastic", "--dataset", str(i.missing), "--probes", str(BUNDLED_PROBES),
            "--out", str(o)], "missing", "not found"),
        ("--dataset", "a folder without index.json", lambda i, o: [
            "--class", "plastic", "--dataset", str(BUNDLED_PROBES), "--probes",
            str(BUNDLED_PROBES), "--out", str(o)], None, "no index.json"),
        ("--dataset", "a corrupt index.json", lambda i, o: [
            "--class", "plastic", "--dataset", str(i.corrupt_index.parent), "--probes",
            str(BUNDLED_PROBES), "--out", str(o)], "corrupt_index",
         "cannot read the dataset index"),
        *_model_cases(sa_evaluate), *_class_case(sa_evaluate), *_out_cases(sa_evaluate)]],
]
"""(command, argument, bad form, argv builder (BadInputs, out folder), name of the BadInputs
path the message must name or None, expected message fragment)."""


FAULT_COMMANDS = {
    "render-dataset": ("render.cli.render_dataset", lambda out: [
        "--probes", str(BUNDLED_PROBES), "--svbrdfs", str(BUNDLED_MATERIALS), "--out", str(out),
        "--resolution", "16", "--render-size", "32", "--rotations", "2", "--crops", "2",
        "--spp", "4", "--test-materials", "0.34", "--test-probes", "0.34"]),
    "sa-train": ("train.cli.sa_train", lambda out: [
        "--labeled-maps", str(BUNDLED_MATERIALS), "--probes", str(BUNDLED_PROBES), "--out",
        str(out), "--network", "small", "--input-size", "32", "--levels", "3", "--render-size",
        "48", "--epoch-samples", "32", "--batch-size", "8", "--labeled-epochs", "2",
        "--self-augmented-epochs", "1", "--unlabeled", str(REPO / "scenes" / "photos"),
        "--checkpoint-every", "3", "--log-every", "2"]),
    "sa-validate": ("train.cli.sa_validate", lambda out: [
        "--probes", str(BUNDLED_PROBES), "--out", str(out), "--config", "toy", "--patterns",
        "2x2x2"]),
    "sa-estimate": ("train.cli.sa_estimate", lambda out: [
        *map(str, fault_photos()), "--out", str(out), "--max-side", "48"]),
    "sa-evaluate": ("train.cli.sa_evaluate", lambda out: [
        "--class", "plastic", "--materials", str(BUNDLED_MATERIALS), "--probes",
        str(BUNDLED_PROBES), "--out", str(out), "--samples", "8", "--sample-size", "64",
        "--relights", "1"]),
}
"""The fault matrix's small runs: (module, argv builder (output folder))."""


@functools.cache
def fault_photos():
    """Four photos for the sa-estimate batch of the fault matrix: 96 px crops of the bundled
    brick photo, written once per process into a temporary folder that is removed when the
    process exits (the same paths for every run of a process, whose results name them)."""
    folder = Path(tempfile.mkdtemp(prefix="fault-photos-"))
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    with Image.open(BUNDLED_PHOTO) as photo:
        photo = photo.convert("RGB")
    paths = []
    for k in range(4):
        path = folder / f"photo-{k}.png"
        photo.crop((100 * k, 100, 100 * k + 96, 196)).save(path)
        paths.append(path)
    return paths
KILLS = 4
"""SIGKILLs per command, each at a seeded random moment, each followed by the same command."""
STOPS = 2
"""SIGTERMs to sa-train, each at a seeded random moment, each followed by the same command."""
FILE_SIZE_LIMITS = {"render-dataset": 20_000, "sa-train": 200_000, "sa-validate": 5_000,
                    "sa-estimate": 20_000, "sa-evaluate": 2_000}
"""Bytes a file may grow to in the full-disk cases (RLIMIT_FSIZE): less than some output."""
FAULTS = [
    *[(command, f"kill -9 at {KILLS} seeded random moments, then the same command",
       "the same files (dataset, estimates; times left out), weights and history (training) "
       "or results (validation, evaluation) as an uninterrupted run; no partial file under a "
       "final name") for command in FAULT_COMMANDS],
    ("sa-train", f"SIGTERM at {STOPS} seeded random moments, then the same command",
     "it stops after the step it is taking, with that step's checkpoint and a line `stopped "
     "by SIGTERM at step N`, exit status 143 (a signal before training starts ends it as "
     "SIGTERM does); the next run ends with an uninterrupted run's weights and evaluations"),
    ("sa-estimate, sa-evaluate, render-dataset, sa-train, sa-validate",
     "a second run on a folder a live run writes into",
     "`Error: OUT: another run is writing into this folder (COMMAND, process PID) ...`; a "
     "killed run's lock ends with it"),
    ("sa-estimate", "the same folder with another model, class, probe or `--max-side`",
     "`Error: OUT/config.json: ... (differing: OPTIONS) ...`, naming them; `--overwrite` "
     "estimates every photo again"),
    *[(command, f"disk full (files limited to {limit:,} bytes)",
       "`Error: PATH: cannot write (... File too large)`, no partial file; the next run ends "
       "as an uninterrupted one") for command, limit in FILE_SIZE_LIMITS.items()],
    ("sa-train", "newest checkpoint truncated", "`Error: CHECKPOINT: cannot read checkpoint "
     "safely ...`; once it is removed, the next run ends as an uninterrupted one"),
    ("all", "read-only output folder", "not tested: CI runs as root, which writes into "
     "read-only folders"),
]
"""(command, fault, what must happen), as docs/reliability.md lists them."""


def markdown():
    """docs/reliability.md's text."""
    lines = [
        "# Reliability: resume, faults and bad input",
        "",
        "Generated from `tests/reliability_cases.py` by `python -m tests.reliability_cases`; "
        "`tests/test_fault_matrix.py` and `tests/test_bad_input_matrix.py` run every case, and "
        "a test checks that this file is current.",
        "",
        "## Resume",
        "",
        "Every command that resumes (`render-dataset`, `sa-train`, `sa-validate`, `sa-estimate`, "
        "`sa-evaluate`) continues an output folder only with the options it was started with "
        "(`render/common/resume.py`; model files and probes compared by their SHA-256), except "
        "those that do not change the result: the output path (a moved folder resumes), the "
        "device, worker counts, logging and checkpoint intervals, and `sa-estimate`'s list of "
        "photos (a photo added to the batch is estimated, the finished ones skipped). Any other "
        "difference is refused, naming the differing options. One run at a time writes into a "
        "folder: a lock (`render/common/folder_lock.py`, `flock`) that the kernel releases when "
        "its process ends, killed or not. `make-materials` skips the sets already written and "
        "refuses a set made with other options.",
        "",
        "## Faults",
        "",
        "Slow tests: `make test-slow`, which CI runs after `make test`.",
        "",
        "| command | fault | what must happen |",
        "| --- | --- | --- |",
        *[f"| `{command}` | {fault} | {outcome} |" for command, fault, outcome in FAULTS],
        "",
        "## Bad input",
        "",
        "Every case must end with a non-zero exit status and one line `Error: ...` that "
        "names the bad path (where there is one) and contains the message below; no "
        "traceback; nothing written into the output folder, and a file already there left as "
        "it was.",
        "",
        "| command | cases |",
        "| --- | --- |",
    ]
    commands = list(dict.fromkeys(case[0] for case in CASES))
    lines += [f"| `{c}` | {sum(case[0] == c for case in CASES)} |" for c in commands]
    for command in commands:
        lines += ["", f"### `{command}`", "", "| argument | bad form | message contains |",
                  "| --- | --- | --- |"]
        lines += [f"| `{argument}` | {form} | `{expected}` |"
                  for name, argument, form, _, _, expected in CASES if name == command]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    DOC.write_text(markdown())
    print(f"wrote {DOC}: {len(CASES)} cases")
