"""benchmarks/gpu_figures.py at toy size on the CPU: every step leaves its JSON, the table
names every figure, and a second call keeps the finished steps (it runs none again).
Slow: CI runs it after the quick suite (``make test-slow``)."""

import json
import subprocess
import sys

import pytest

from tests.conftest import REPO

pytestmark = pytest.mark.slow
STEPS = ("mitsuba_llvm", "mitsuba_cuda", "torch_b16_mix", "torch_b16_a0.02", "torch_b64_mix",
         "torch_b64_a0.02", "train_compact", "train_paper", "estimate_1024", "validate_seed0")


def gpu_figures(out):
    return subprocess.run([sys.executable, str(REPO / "benchmarks" / "gpu_figures.py"), "--out",
                           str(out), "--device", "cpu", "--toy", "--seeds", "1", "--budget",
                           "900"], cwd=REPO, capture_output=True, text=True)


def test_toy_run_writes_every_figure_and_continues(tmp_path):
    first = gpu_figures(tmp_path)
    assert first.returncode == 0, first.stderr
    for step in STEPS:
        assert (tmp_path / f"{step}.json").is_file(), (step, first.stderr)
    figures = json.loads((tmp_path / "gpu_figures.json").read_text())["figures"]
    assert sorted(figures) == sorted(STEPS)
    assert figures["mitsuba_cuda"]["min_psnr_db_vs_compared"] > 100  # the same variant twice
    assert figures["estimate_1024"]["map_size"] == [64, 48]
    table = (tmp_path / "gpu_figures.md").read_text()
    assert table.count("| torch renderer, batch 2") == 4 and "sa-validate 2x2x2, seed0" in table
    stamps = {step: (tmp_path / f"{step}.json").stat().st_mtime_ns for step in STEPS}
    again = gpu_figures(tmp_path)
    assert again.returncode == 0, again.stderr
    assert stamps == {step: (tmp_path / f"{step}.json").stat().st_mtime_ns for step in STEPS}
    assert (tmp_path / "gpu_figures.md").read_text() == table
