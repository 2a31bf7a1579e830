"""render-dataset end to end on tiny data: output format, determinism, resume after kill -9."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from render.cli.render_dataset import main
from render.common.labels import relative_labels, rotate_quarter_turns
from tests.conftest import BUNDLED_MATERIALS, BUNDLED_PROBES, REPO, SHARED_DATA, needs_shared

TINY = ["--resolution", "24", "--render-size", "32", "--rotations", "2", "--crops", "2",
        "--spp", "64"]


def render(out, *extra, probes=BUNDLED_PROBES, svbrdfs=BUNDLED_MATERIALS):
    result = CliRunner().invoke(main, ["--probes", str(probes), "--svbrdfs", str(svbrdfs),
                                       "--out", str(out), *TINY, *extra])
    assert result.exit_code == 0, result.output
    return json.loads((Path(out) / "index.json").read_text())


def sample_arrays(folder):
    arrays = {}
    for path in sorted((Path(folder) / "samples").glob("*.npz")):
        with np.load(path) as data:
            arrays[path.name] = {k: data[k] for k in data.files}
    return arrays


def dataset_files(folder):
    """{relative path: bytes} of every sample and task marker of a dataset folder."""
    folder = Path(folder)
    return {str(path.relative_to(folder)): path.read_bytes()
            for path in sorted([*folder.glob("samples/*.npz"), *folder.glob("tasks/*.json")])}


def assert_same_samples(a, b):
    assert a.keys() == b.keys()
    for name in a:
        for key in a[name]:
            assert np.array_equal(a[name][key], b[name][key]), (name, key)


@pytest.fixture(scope="module")
def reference_dataset(tmp_path_factory):
    out = tmp_path_factory.mktemp("reference") / "ds"
    return out, render(out, "--test-materials", "0.34", "--test-probes", "0.34")


def test_output_format(reference_dataset):
    out, index = reference_dataset
    # 3 materials x 3 probes: 2x2 train pairs + 1x1 test pair, 2 rotations, 2 crops each
    assert index["count"] == (4 + 1) * 2 * 2
    assert index["splits"] == {"train": 16, "test": 4}
    test_pairs = {(s["material"], s["probe"]) for s in index["samples"] if s["split"] == "test"}
    train_pairs = {(s["material"], s["probe"]) for s in index["samples"] if s["split"] == "train"}
    assert len(test_pairs) == 1
    (test_material, test_probe), = test_pairs
    assert all(m != test_material and p != test_probe for m, p in train_pairs)
    assert (out / "contact_sheet.png").stat().st_size > 0
    assert json.loads((out / "config.json").read_text())["spp"] == 64
    with np.load(out / index["samples"][0]["file"]) as data:
        assert data["image"].shape == (24, 24, 3) and data["image"].dtype == np.float16
        assert 0 <= data["image"].min() and data["image"].max() <= 1
        assert abs(float(data["albedo"].astype(np.float32).mean()) - 0.5) < 1e-3
        np.testing.assert_allclose(np.linalg.norm(data["normal"].astype(np.float32), axis=-1),
                                   1, atol=2e-3)
        provenance = json.loads(str(data["provenance"]))
    for key in ("material", "probe", "rotation_deg", "exposure", "render_seed", "spp", "crop"):
        assert key in provenance


def test_same_seed_same_dataset_whatever_the_workers(reference_dataset, tmp_path):
    out, index = reference_dataset
    again = render(tmp_path / "ds", "--test-materials", "0.34", "--test-probes", "0.34",
                   "--workers", "2")
    assert again["samples"] == index["samples"]
    assert dataset_files(out) == dataset_files(tmp_path / "ds")


@pytest.mark.slow  # end to end, several processes: make test-slow
def test_a_local_ray_cluster_renders_byte_identical_files(reference_dataset, tmp_path):
    """render-dataset --ray on a Ray instance of 2 worker CPUs, chunks of 3 tasks, against the
    one-process reference: same index, same bytes in every sample and task marker."""
    out, index = reference_dataset
    command = [sys.executable, "-m", "render.cli.render_dataset", "--probes", str(BUNDLED_PROBES),
               "--svbrdfs", str(BUNDLED_MATERIALS), "--out", str(tmp_path / "ds"), *TINY,
               "--test-materials", "0.34", "--test-probes", "0.34", "--ray", "--workers", "2",
               "--ray-chunk", "3"]
    result = subprocess.run(command, cwd=REPO, capture_output=True, text=True)
    assert result.returncode == 0, result.stderr[-3000:]
    assert "Ray cluster: 2.0 CPUs" in result.stderr
    again = json.loads((tmp_path / "ds" / "index.json").read_text())
    assert again["samples"] == index["samples"]
    files = dataset_files(tmp_path / "ds")
    assert len(files) == index["count"] + index["count"] // 2  # 2 crops per task marker
    assert files == dataset_files(out)


def test_other_seed_other_dataset(reference_dataset, tmp_path):
    out, index = reference_dataset
    other = render(tmp_path / "ds", "--test-materials", "0.34", "--test-probes", "0.34",
                   "--seed", "1")
    assert [s["rotation_deg"] for s in other["samples"]] != \
        [s["rotation_deg"] for s in index["samples"]]


def test_resume_after_kill_9(reference_dataset, tmp_path):
    """Kill a run as soon as its first task is written, re-run: same files as uninterrupted."""
    out, _ = reference_dataset
    partial = tmp_path / "ds"
    command = [sys.executable, "-m", "render.cli.render_dataset", "--probes", str(BUNDLED_PROBES),
               "--svbrdfs", str(BUNDLED_MATERIALS), "--out", str(partial), *TINY,
               "--test-materials", "0.34", "--test-probes", "0.34"]
    process = subprocess.Popen(command, cwd=REPO, stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    while not list(partial.glob("tasks/*.json")) and time.monotonic() < deadline:
        time.sleep(0.01)  # waiting for the first task marker, not timing anything
    os.kill(process.pid, signal.SIGKILL)
    process.wait()
    done = len(list(partial.glob("tasks/*.json")))
    assert 1 <= done < 10, "the run should have been interrupted part-way"
    assert not (partial / "index.json").exists()
    result = CliRunner().invoke(main, command[3:])
    assert result.exit_code == 0, result.output
    assert not list(partial.rglob(".*.tmp*"))
    assert_same_samples(sample_arrays(out), sample_arrays(partial))


def test_resume_refuses_other_options(reference_dataset):
    out, _ = reference_dataset
    result = CliRunner().invoke(main, ["--probes", str(BUNDLED_PROBES), "--svbrdfs",
                                       str(BUNDLED_MATERIALS), "--out", str(out), *TINY,
                                       "--seed", "5"])
    assert result.exit_code == 1 and "differing: seed" in result.output


def test_quarter_turns_turn_the_normals_with_the_picture():
    """Normals of a rotated height field equal the rotated normals of the height field."""
    y, x = np.mgrid[0:16, 0:16].astype(float)
    height = np.sin(0.4 * x) + 0.3 * y + 0.05 * x * y

    def normals(h):  # x right, y up: image rows grow downward, so dh/dy_up = -dh/drow
        dh_drow, dh_dcol = np.gradient(h)
        n = np.stack([-dh_dcol, dh_drow, np.ones_like(h)], -1)
        return n / np.linalg.norm(n, axis=-1, keepdims=True)

    for turns in range(4):
        _, _, turned = rotate_quarter_turns(np.zeros((16, 16, 3)), np.zeros((16, 16, 3)),
                                            normals(height), turns)
        np.testing.assert_allclose(turned, normals(np.rot90(height, turns)), atol=1e-12)


def test_relative_labels():
    albedo = np.random.default_rng(0).uniform(0.1, 0.9, (8, 8, 3))
    relative, log_specular = relative_labels(albedo * 3, np.array([0.3, 0.3, 0.3]))
    relative2, _ = relative_labels(albedo, np.array([0.1, 0.1, 0.1]))
    assert relative.mean() == pytest.approx(0.5)
    np.testing.assert_allclose(relative, relative2)  # invariant to a common scale
    np.testing.assert_allclose(log_specular, np.log(0.3 / (6 * albedo.mean())))


def test_training_reader_does_not_import_mitsuba(reference_dataset):
    out, index = reference_dataset
    code = ("import sys; from train.data.labeled_dataset import LabeledDataset; "
            f"d = LabeledDataset({str(out)!r}, 'test'); item = d[0]; "
            "assert item['image'].shape == (3, 24, 24), item['image'].shape; "
            "assert 'mitsuba' not in sys.modules and 'drjit' not in sys.modules; print(len(d))")
    result = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True,
                            text=True)
    assert result.returncode == 0, result.stderr
    assert int(result.stdout) == index["splits"]["test"]


@needs_shared
def test_every_shared_material_and_probe_renders(tmp_path):
    index = render(tmp_path / "ds", "--rotations", "1", "--crops", "1", "--spp", "16",
                   "--resolution", "16", "--render-size", "16", "--workers", "2",
                   probes=SHARED_DATA / "probes", svbrdfs=SHARED_DATA / "svbrdfs")
    assert {s["material"] for s in index["samples"]} == \
        {p.name for p in (SHARED_DATA / "svbrdfs").iterdir() if p.is_dir()}
    assert {s["probe"] for s in index["samples"]} == \
        {p.stem for p in (SHARED_DATA / "probes").glob("*.exr")}
