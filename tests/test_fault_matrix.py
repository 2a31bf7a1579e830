"""The fault matrix (tests/reliability_cases.py): ``render-dataset``, ``sa-train``,
``sa-validate``, ``sa-estimate`` and ``sa-evaluate`` killed with SIGKILL at seeded random
moments, then run again with the same command, end exactly as an uninterrupted run: identical
dataset files, bit-identical weights and history, identical validation results, identical
estimate files (times left out), identical evaluation results; and no file under its final
name is ever partial; ``sa-train`` stopped by SIGTERM keeps every step it took. Also: a disk
that fills up (a file-size limit) and a truncated checkpoint give one-line errors naming the
path, and the next good run completes. Marked slow: CI runs them after the quick suite
(``make test-slow``).

Not covered: a read-only output folder. These tests run as root on CI, and root writes into
read-only folders, so the case cannot be produced here.
"""

import json
import os
import re
import resource
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from render.common.images import read_image

from tests.conftest import REPO, signal_once
from tests.reliability_cases import FAULT_COMMANDS as COMMANDS
from tests.reliability_cases import FILE_SIZE_LIMITS, KILLS, STOPS
from train.networks.checkpoints import checkpoint_files, load_checkpoint

pytestmark = pytest.mark.slow
UNCOMPARED = {"ms_per_step", "seconds", "out", "network_ms", "full_resolution_ms"}
"""Fields that measure time or name the output folder, not results: left out of comparisons."""


def run(command, out, **options):
    module, argv = COMMANDS[command]
    return subprocess.run([sys.executable, "-m", module, *argv(out)], cwd=REPO,
                          capture_output=True, text=True, **options)


def files(folder):
    """Files under ``folder`` by relative path; hidden ones (temporaries ``.name.tmpPID``, a
    photo folder being written ``.stem.partial/``, the ``.lock``) and the append-only
    TensorBoard logs left out. Safe while a run renames folders in it (os.walk skips a folder
    that is gone by the time it is listed; hidden folders are never entered)."""
    found = {}
    for root, folders, names in os.walk(folder):
        folders[:] = [name for name in folders if not name.startswith(".")]
        for name in names:
            path = Path(root) / name
            relative = path.relative_to(folder)
            if not name.startswith(".") and "tensorboard" not in relative.parts:
                found[str(relative)] = path
    return dict(sorted(found.items()))


def assert_complete(path):
    """Fail if ``path`` is not a whole file of its kind."""
    if path.suffix == ".json":
        json.loads(path.read_text())
    elif path.suffix == ".npz":
        with np.load(path) as data:
            for name in data.files:
                data[name]
    elif path.suffix == ".pt":
        load_checkpoint(path)
    elif path.suffix in (".png", ".jpg"):
        with Image.open(path) as image:
            image.load()
    elif path.suffix == ".exr":
        read_image(path)
    elif path.suffix == ".glb":  # the binary glTF header's length is the file's
        data = path.read_bytes()
        assert data[:4] == b"glTF" and int.from_bytes(data[8:12], "little") == len(data), path
    elif path.suffix in (".xml", ".html"):
        assert path.read_text().rstrip().endswith(("</scene>", "</html>")), path
    else:
        assert path.suffix in (".csv", ".md"), path


def comparable(value):
    if isinstance(value, dict):
        return {k: comparable(v) for k, v in value.items() if k not in UNCOMPARED}
    if isinstance(value, list):
        return [comparable(v) for v in value]
    return value


def result_of(command, out):
    """What must equal an uninterrupted run's: {name: comparable content}."""
    found = files(out)
    if command == "render-dataset":
        return {name: comparable(json.loads(path.read_text())) if path.suffix == ".json"
                else path.read_bytes() for name, path in found.items()}
    if command == "sa-train":
        newest = load_checkpoint(checkpoint_files(out / "checkpoints")[-1])
        weights = {name: tensor.numpy().tobytes() for name, tensor in newest["model"].items()}
        return {"checkpoints": [p.name for p in checkpoint_files(out / "checkpoints")],
                "weights": weights, "history": comparable(newest["history"]),
                "history.json": comparable(json.loads(found["history.json"].read_text()))}
    if command == "sa-estimate":  # every file; the times in the report and page left out
        return {name: comparable(json.loads(path.read_text())) if path.suffix == ".json"
                else re.sub(r"[0-9.]+ ms", "ms", path.read_text()) if path.suffix == ".html"
                else path.read_bytes() for name, path in found.items()}
    return {name: comparable(json.loads(path.read_text())) for name, path in found.items()
            if name.endswith(".json")}


def signal_at_random_moment(command, out, rng, files_at_end, signal_number=signal.SIGKILL):
    """Start ``command`` and send it ``signal_number`` once ``out`` holds a random number of
    its final files (fewer than ``files_at_end``), plus a random fraction of a second; returns
    its exit status and stderr, or None if it finished before the signal."""
    module, argv = COMMANDS[command]
    target, extra = int(rng.integers(files_at_end)), float(rng.uniform(0.0, 0.5))
    status, stderr, signalled = signal_once(
        [sys.executable, "-m", module, *argv(out)],
        lambda: out.exists() and len(files(out)) >= target, signal_number, extra)
    return (status, stderr) if signalled else None


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory):
    """Each command's result when run once without faults, and its number of files."""
    results = {}
    for command in COMMANDS:
        out = tmp_path_factory.mktemp("uninterrupted") / command
        finished = run(command, out)
        assert finished.returncode == 0, finished.stderr
        results[command] = (result_of(command, out), len(files(out)))
    return results


@pytest.mark.parametrize("command", list(COMMANDS))
def test_killed_runs_end_as_uninterrupted_ones(command, uninterrupted, tmp_path):
    """KILLS runs killed while they work; a moment that falls after the run ended is drawn
    again (at most 3 KILLS more times: in a fresh clone, 6 of 10 draws once fell after a
    render-dataset run had ended, leaving 4 kills)."""
    expected, files_at_end = uninterrupted[command]
    rng = np.random.default_rng(list(COMMANDS).index(command))
    killed = 0
    for attempt in range(4 * KILLS):
        if killed == KILLS:
            break
        out = tmp_path / f"attempt-{attempt}"
        killed += signal_at_random_moment(command, out, rng, files_at_end) is not None
        for path in files(out).values():  # never a partial file under its final name
            assert_complete(path)
        again = run(command, out)
        assert again.returncode == 0, again.stderr
        assert result_of(command, out) == expected, f"attempt {attempt}"
    assert killed == KILLS


def test_stopped_training_loses_no_step_and_ends_as_an_uninterrupted_run(uninterrupted,
                                                                         tmp_path):
    """STOPS runs sent SIGTERM while they work (a moment after the run ended is drawn again;
    here both came during training, at least one must): each stops with the checkpoint of the
    step it took last, and the same command then ends
    with an uninterrupted run's weights and test evaluations (its train history has one more
    logged interval, the one the stop closed)."""
    expected, files_at_end = uninterrupted["sa-train"]
    rng = np.random.default_rng(len(COMMANDS))
    stopped, in_training = 0, 0
    for attempt in range(4 * STOPS):
        if stopped == STOPS:
            break
        out = tmp_path / f"attempt-{attempt}"
        result = signal_at_random_moment("sa-train", out, rng, files_at_end, signal.SIGTERM)
        if result is not None:
            status, stderr = result
            stopped += 1
            if status == 128 + signal.SIGTERM:
                step = int(re.search(r"stopped by SIGTERM at step (\d+):", stderr).group(1))
                newest = load_checkpoint(checkpoint_files(out / "checkpoints")[-1])
                assert newest["step"] == step == newest["history"]["train"][-1]["step"]
                in_training += 1
            else:  # the signal came before the training loop (SIGTERM's own end) or in its
                assert status in (-signal.SIGTERM, 0), stderr[-2000:]  # last step (finished)
        for path in files(out).values():
            assert_complete(path)
        again = run("sa-train", out)
        assert again.returncode == 0, again.stderr
        resumed = result_of("sa-train", out)
        assert resumed["weights"] == expected["weights"], f"attempt {attempt}"
        assert resumed["history"]["test"] == expected["history"]["test"], f"attempt {attempt}"
    assert stopped == STOPS and in_training > 0


def limit_file_size(limit_bytes):
    def apply():
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, limit_bytes))
    return apply


@pytest.mark.parametrize("command, limit", FILE_SIZE_LIMITS.items())
def test_full_disk_is_one_line_and_the_next_run_completes(command, limit, uninterrupted,
                                                          tmp_path):
    out = tmp_path / "out"
    full = run(command, out, preexec_fn=limit_file_size(limit))
    assert full.returncode != 0
    assert "Traceback" not in full.stderr, full.stderr
    error = full.stderr.strip().splitlines()[-1]
    assert error.startswith("Error: ") and "cannot write" in error, error
    assert "File too large" in error, error
    for path in files(out).values():
        assert_complete(path)
    again = run(command, out)
    assert again.returncode == 0, again.stderr
    assert result_of(command, out) == uninterrupted[command][0]


def test_truncated_checkpoint_is_named_and_the_run_resumes_without_it(uninterrupted, tmp_path):
    out = tmp_path / "run"
    assert run("sa-train", out).returncode == 0
    kept = checkpoint_files(out / "checkpoints")
    newest = kept[-1]
    newest.write_bytes(newest.read_bytes()[:1000])
    for path in kept[:-1]:  # the run is at its newest checkpoint's step only
        path.unlink()
    truncated = run("sa-train", out)
    assert truncated.returncode != 0 and "Traceback" not in truncated.stderr
    error = truncated.stderr.strip().splitlines()[-1]
    assert error.startswith(f"Error: {newest}: cannot read checkpoint safely"), error
    newest.unlink()  # the user removes it: the run starts again and ends as uninterrupted
    again = run("sa-train", out)
    assert again.returncode == 0, again.stderr
    expected = uninterrupted["sa-train"][0]
    assert result_of("sa-train", out) == expected
