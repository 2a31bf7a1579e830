"""sa-estimate batches that continue (train.estimation.batch) and the folder lock
(render.common.folder_lock): a re-run skips the finished photos and estimates the new ones, a
folder made with other options is refused naming them, ``--overwrite`` redoes every photo,
and a second run on a folder a live run holds is refused until that run is killed. The kill -9
cases are in the fault matrix (tests/test_fault_matrix.py)."""

import json
import os
import subprocess
import sys

import pytest

from render.common.errors import InputError
from render.common.folder_lock import lock_folder
from tests.conftest import REPO
from tests.reliability_cases import fault_photos

HOLD_LOCK = ("import sys; from render.common.folder_lock import lock_folder; "
             "lock_folder(sys.argv[1], 'holder'); print('locked', flush=True); sys.stdin.read()")
"""A process that takes a folder's lock, says so, and holds it until its stdin closes."""


def sa_estimate(photos, out, *options):
    return subprocess.run([sys.executable, "-m", "train.cli.sa_estimate", *map(str, photos),
                           "--out", str(out), "--max-side", "48", *options], cwd=REPO,
                          capture_output=True, text=True)


def last_error(result):
    assert result.returncode != 0 and "Traceback" not in result.stderr, result.stderr
    return result.stderr.strip().splitlines()[-1]


def test_a_rerun_skips_finished_photos_and_estimates_new_ones(tmp_path):
    photos, out = fault_photos(), tmp_path / "out"
    first = sa_estimate(photos[:2], out)
    assert first.returncode == 0, first.stderr
    made = {p.name: (out / p.stem / "albedo.exr").stat().st_mtime_ns for p in photos[:2]}
    again = sa_estimate(photos[:3], out)
    assert again.returncode == 0, again.stderr
    assert "done=1, left=0, skipped=2" in again.stderr
    assert made == {p.name: (out / p.stem / "albedo.exr").stat().st_mtime_ns
                    for p in photos[:2]}  # the finished ones were not written again
    reports = [json.loads(line) for line in again.stdout.splitlines()]
    assert [r["photo"] for r in reports] == [str(p) for p in photos[:3]]
    assert all((out / p.stem / "estimate.json").is_file() for p in photos[:3])
    assert "photo-2" in (out / "report.html").read_text()


def test_other_options_are_refused_by_name_and_overwrite_redoes(tmp_path):
    photos, out = fault_photos()[:1], tmp_path / "out"
    assert sa_estimate(photos, out).returncode == 0
    before = (out / photos[0].stem / "albedo.exr").read_bytes()
    error = last_error(sa_estimate(photos, out, "--class", "wood"))
    assert error.startswith(f"Error: {out / 'config.json'}: ") and "differing: class" in error
    assert (out / photos[0].stem / "albedo.exr").read_bytes() == before  # nothing lost
    redone = sa_estimate(photos, out, "--class", "wood", "--overwrite")
    assert redone.returncode == 0, redone.stderr
    assert "svbrdf-wood" in json.loads(redone.stdout)["model"]
    assert (out / photos[0].stem / "albedo.exr").read_bytes() != before
    assert json.loads((out / "config.json").read_text())["class"] == "wood"


def test_a_photo_changed_under_its_name_is_refused(tmp_path):
    photo, out = tmp_path / "photo.png", tmp_path / "out"
    photo.write_bytes(fault_photos()[0].read_bytes())
    assert sa_estimate([photo], out).returncode == 0
    photo.write_bytes(fault_photos()[1].read_bytes())
    error = last_error(sa_estimate([photo], out))
    assert error.startswith(f"Error: {photo}: ") and "another file of this name" in error


def test_a_live_run_holds_the_folder_until_it_is_killed(tmp_path):
    out = tmp_path / "out"
    holder = subprocess.Popen([sys.executable, "-c", HOLD_LOCK, str(out)], cwd=REPO,
                              stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        error = last_error(sa_estimate(fault_photos()[:1], out))
        assert error == (f"Error: {out}: another run is writing into this folder (holder, "
                         f"process {holder.pid}); wait for it to end or use another --out")
        with pytest.raises(InputError, match="another run is writing"):
            lock_folder(out, "this test")
    finally:
        holder.kill()  # SIGKILL: the kernel releases its lock
        holder.wait()
    finished = sa_estimate(fault_photos()[:1], out)
    assert finished.returncode == 0, finished.stderr


def test_the_lock_is_reentrant_within_a_process(tmp_path):
    lock_folder(tmp_path / "out", "first")
    lock_folder(tmp_path / "out", "second")  # the same process: no refusal
    assert (tmp_path / "out" / ".lock").read_text() == f"first, process {os.getpid()}\n"
