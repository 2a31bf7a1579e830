"""scripts/release.py: which sets each run trains on, and the release at toy size end to end
(slow: CI runs it after the quick suite, ``make test-slow``)."""

import json
import subprocess
import sys

import pytest
from safetensors import safe_open

from tests.conftest import REPO, SHARED_DATA, needs_shared

sys.path.insert(0, str(REPO / "scripts"))
from real_validation import FOLDS, TEST_PROBES, TEST_SETS, VALIDATION_PROBES  # noqa: E402
from release import (  # noqa: E402
    RECIPE,
    SIZES,
    real_training_sets,
    run_folds,
    total_steps,
    training_probes,
)


def test_a_fold_run_never_trains_on_its_fold_or_the_test():
    for fold, names in FOLDS.items():
        sets = set(real_training_sets(fold))
        assert not sets & set(names) and not sets & set(TEST_SETS)
        assert len(sets) == sum(len(n) for f, n in FOLDS.items() if f != fold)
    assert not set(real_training_sets("all")) & set(TEST_SETS)


def test_networks_on_real_sets_have_a_run_per_fold():
    for network in RECIPE:
        assert run_folds(network) == ((*FOLDS, "all") if network.real_sets else ("all",))


def test_runs_are_whole_epochs():
    for size in SIZES.values():
        per_epoch = size.epoch_samples // size.batch_size
        for network in RECIPE:
            steps = total_steps(network, size)
            assert steps % per_epoch == 0 and steps >= (size.steps or network.steps)


@needs_shared
def test_no_run_is_lit_by_a_held_out_probe():
    probes = training_probes(SHARED_DATA)
    held_out = len(VALIDATION_PROBES) + len(TEST_PROBES)
    assert len(probes) == len(list((SHARED_DATA / "probes").glob("*.exr"))) - held_out == 26
    assert not set(probes) & (set(VALIDATION_PROBES) | set(TEST_PROBES))


def release(work, minutes):
    return subprocess.run([sys.executable, "scripts/release.py", "--out", str(work),
                           "--size", "toy", "--train-minutes", str(minutes)],
                          cwd=REPO, capture_output=True, text=True)


@pytest.mark.slow
@needs_shared
def test_the_release_at_toy_size(tmp_path):
    work = tmp_path / "release"
    stopped = release(work, 0)  # no minutes: no run trains, nothing to export
    assert stopped.returncode == 1
    assert "no checkpoint to export" in stopped.stderr.splitlines()[-1]

    done = release(work, 60)  # an upper bound: the runs end sooner
    assert done.returncode == 0, done.stderr[-2000:]
    card = (work / "card.md").read_text()
    for network in RECIPE:
        for fold in run_folds(network):
            steps = total_steps(network, SIZES["toy"])
            assert f"| {network.name}-{fold} | {steps} of {steps} |" in card
            path = work / "files" / fold / f"svbrdf-{network.name}.safetensors"
            with safe_open(str(path), framework="pt") as file:
                metadata = file.metadata()
            assert metadata["command"].startswith("scripts/release.py --size toy")
            assert str(tmp_path) not in json.dumps(metadata)  # no machine's paths
            real = json.loads(metadata["real_sets"])
            assert real == (real_training_sets(fold) if network.real_sets else [])
        for fold in FOLDS:
            assert f"| {fold} | {network.name} | {SIZES['toy'].photos} |" in card
        assert f"| test | {network.name} | {SIZES['toy'].photos} |" in card

    files = sorted((work / "files").rglob("*.safetensors"))
    before = {path: path.read_bytes() for path in files}
    again = release(work, 60)  # all done: nothing is trained or exported again
    assert again.returncode == 0, again.stderr[-2000:]
    assert {path: path.read_bytes() for path in files} == before
