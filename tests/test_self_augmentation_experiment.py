"""scripts/self_augmentation_experiment.py: its inputs are checked before anything runs."""

import subprocess
import sys

from tests.conftest import BUNDLED_MATERIALS, BUNDLED_PROBES, REPO


def test_unlabeled_photos_from_a_folder_without_them_are_refused(tmp_path):
    """--unlabeled-from a folder that is not another experiment's: a one-line error naming it,
    before any training or output."""
    (tmp_path / "not-an-experiment").mkdir()
    (tmp_path / "heldout").mkdir()
    command = [sys.executable, str(REPO / "scripts" / "self_augmentation_experiment.py"),
               "--sets", str(BUNDLED_MATERIALS), "--probes", str(BUNDLED_PROBES),
               "--heldout", str(tmp_path / "heldout"), "--heldout-probes", str(BUNDLED_PROBES),
               "--out", str(tmp_path / "out"), "--pool", "2", "--labeled", "1",
               "--unlabeled-from", str(tmp_path / "not-an-experiment")]
    result = subprocess.run(command, cwd=REPO, capture_output=True, text=True)
    assert result.returncode != 0
    assert (f"{tmp_path / 'not-an-experiment'}: no unlabeled photos in it"
            in result.stderr.replace("\n", " ")), result.stderr
    assert not (tmp_path / "out").exists()
