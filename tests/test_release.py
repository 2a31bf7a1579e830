"""scripts/release.py: which sets and probes each run trains on, and the release at toy size end
to end (slow: CI runs it after the quick suite, ``make test-slow``)."""

import json
import signal
import subprocess
import sys

import pytest
from safetensors import safe_open

from render.common.errors import InputError
from render.common.resume import file_digest
from tests.conftest import REPO, SHARED_DATA, needs_shared
from train.estimation.network_choice import CLASSES

sys.path.insert(0, str(REPO / "scripts"))
from procedural_test import HELD_OUT_PAIRS, SEED  # noqa: E402
from procedural_test import SIZES as PROCEDURAL_SIZES  # noqa: E402
from procedural_test import groups  # noqa: E402
from real_validation import FOLDS, TEST_PROBES, VALIDATION_PROBES  # noqa: E402
import release  # noqa: E402
from release import (  # noqa: E402
    RECIPE,
    SHIPPED,
    SIZES,
    check_size,
    fresh_run,
    network_steps,
    run_folder,
    ship_rule_failures,
    stage_file,
    time_share,
    total_steps,
    training_probes,
    write_card,
)

SEEDS = {seed for network in RECIPE for stage in network.stages for seed in stage.seeds}


def test_no_run_trains_on_the_procedural_test_seed():
    assert 1 not in SEEDS  # make-materials seed 1: the test


def test_runs_are_whole_epochs():
    for size in SIZES.values():
        per_epoch = size.epoch_samples // size.batch_size
        for network in RECIPE:
            for stage in network.stages:
                steps = total_steps(stage, size)
                assert steps % per_epoch == 0 and steps >= stage.steps * size.step_fraction


def test_the_full_recipe_is_the_shipped_files_steps():
    """models/README.md's stages (plastic less its stage 4, whose albedo network stage 5
    replaced): wood 1,800 + 2,800, plastic 2,000 + 3,000 + 1,600 + 1,200 + 4 x 800, metal
    2,000 + 1,200."""
    assert {network.name: [total_steps(stage, SIZES["full"]) for stage in network.stages]
            for network in RECIPE} == {"wood": [1800, 2800],
                                       "plastic": [2000, 3000, 1600, 1200, 800, 800, 800, 800],
                                       "metal": [2000, 1200]}
    assert sum(network_steps(network, SIZES["cpu"]) for network in RECIPE) == 1700


def test_a_stage_started_from_an_older_export_starts_again(tmp_path):
    network = RECIPE[0]
    run, init = run_folder(tmp_path, network, 1), tmp_path / "first.safetensors"
    init.write_bytes(b"stage 1, 200 steps")
    fresh_run(tmp_path, network, 1, init)  # a new run notes what it starts from
    (run / "checkpoints").mkdir(parents=True)
    stage_file(tmp_path, network, 1).parent.mkdir(parents=True)
    stage_file(tmp_path, network, 1).write_bytes(b"its export")
    fresh_run(tmp_path, network, 1, init)  # the same start: the run is kept
    assert (run / "checkpoints").is_dir() and stage_file(tmp_path, network, 1).is_file()
    init.write_bytes(b"stage 1, 400 steps")
    fresh_run(tmp_path, network, 1, init)  # another start: the run and its export go
    assert not run.exists() and not stage_file(tmp_path, network, 1).exists()
    assert run.with_suffix(".init").read_text() == file_digest(init)


def test_a_work_folder_keeps_its_size(tmp_path):
    check_size(tmp_path, "cpu")
    check_size(tmp_path, "cpu")
    with pytest.raises(InputError, match="made at size cpu, not full"):
        check_size(tmp_path, "full")


def test_the_procedural_test_holds_the_cards_larger_test_and_nothing_trained_on():
    """At size full: 40 sets in 4 groups of 10 with the real sets, 80 more in 4 groups of 20
    without, each group under its own pair of held-out probes; sets of the seed no run
    trains on, lit by probes no run is lit by."""
    found = groups(PROCEDURAL_SIZES["full"])
    assert [(name, pair, len(indices), real) for name, pair, indices, real in found] == [
        ("0", 0, 10, True), ("1", 1, 10, True), ("2", 2, 10, True), ("3", 3, 10, True),
        ("more-0", 0, 20, False), ("more-1", 1, 20, False), ("more-2", 2, 20, False),
        ("more-3", 3, 20, False)]
    assert sorted(i for _, _, indices, _ in found for i in indices) == list(range(120))
    assert SEED not in SEEDS
    held_out = {probe for pair in HELD_OUT_PAIRS for probe in pair}
    assert held_out == set(VALIDATION_PROBES) | set(TEST_PROBES)


@needs_shared
def test_no_run_is_lit_by_a_held_out_probe():
    probes = training_probes(SHARED_DATA)
    held_out = len(VALIDATION_PROBES) + len(TEST_PROBES)
    assert len(probes) == len(list((SHARED_DATA / "probes").glob("*.exr"))) - held_out == 26
    assert not set(probes) & (set(VALIDATION_PROBES) | set(TEST_PROBES))


def test_the_runs_share_the_time_by_their_steps_left_and_the_last_gets_the_rest():
    assert time_share(3600.0, 1, 1000, 4000) == 900.0  # a quarter of the steps waiting
    assert time_share(3600.0, 1, 3200, 3200) == 3600.0  # the last run: all that is left
    assert time_share(3600.0, 2, 3000, 4000) == 3600.0  # never past the deadline
    assert time_share(3600.0, 1, 0, 0) == 0.0


# Stands in for sa-train: notes its start, then does what argv[2] says.
FAKE_SA_TRAIN = """
import os, signal, sys
with open(sys.argv[1], "a") as starts:
    starts.write("started\\n")
if sys.argv[2] == "signal-the-release":  # as a user's kill would; then stop as sa-train does
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGTERM})
    os.kill(os.getppid(), signal.SIGTERM)
    if signal.sigtimedwait({signal.SIGTERM}, 60) is None:
        sys.exit(3)  # the release did not pass the signal on
    sys.exit(128 + signal.SIGTERM)
sys.exit(int(sys.argv[2]))
"""


def fake_training(monkeypatch, tmp_path, behaviour: str):
    """train_runs at toy size with FAKE_SA_TRAIN for sa-train; returns the file of its starts."""
    starts = tmp_path / "starts.txt"
    monkeypatch.setattr(release, "maps_folder", lambda work, network, index: work)
    monkeypatch.setattr(release, "train_command", lambda *arguments: [
        sys.executable, "-c", FAKE_SA_TRAIN, str(starts), behaviour])
    return starts


def test_a_signal_to_the_release_stops_its_sa_train_and_starts_no_other_run(monkeypatch,
                                                                             tmp_path):
    starts = fake_training(monkeypatch, tmp_path, "signal-the-release")
    record, stopped_by = release.train_runs(tmp_path, SIZES["toy"], "cpu", 10.0, 1, "release.py")
    assert stopped_by == signal.SIGTERM
    assert starts.read_text() == "started\n"  # the first run only; it took its SIGTERM
    assert list(record) == [network.name for network in RECIPE]
    assert all(row["steps"] == 0 for row in record.values())


def test_a_stopped_sa_train_stops_the_release_and_a_failed_one_fails_it(monkeypatch, tmp_path):
    stopped, failed = tmp_path / "stopped", tmp_path / "failed"
    stopped.mkdir()
    failed.mkdir()
    starts = fake_training(monkeypatch, stopped, str(128 + signal.SIGINT))
    _, stopped_by = release.train_runs(stopped, SIZES["toy"], "cpu", 10.0, 1, "release.py")
    assert stopped_by == signal.SIGINT and starts.read_text() == "started\n"
    fake_training(monkeypatch, failed, "1")
    with pytest.raises(InputError, match=r"runs/wood-1\.log: sa-train failed \(exit status 1\)"):
        release.train_runs(failed, SIZES["toy"], "cpu", 10.0, 1, "release.py")


def test_an_unfinished_release_has_the_runs_table_and_no_figures(tmp_path):
    record = {"wood": {"steps": 1100, "of_steps": 4600, "seconds": 5713.1}}
    write_card(tmp_path, "scripts/release.py --size full --device cpu", record, None)
    card = (tmp_path / "card.md").read_text()
    assert "| wood | 1100 of 4600 | 95.2 |" in card and "Unfinished" in card
    assert "validation**" not in card
    summary = json.loads((tmp_path / "release.json").read_text())
    assert summary["runs"] == record and "validation" not in summary


def test_a_network_whose_last_stage_has_not_started_has_no_file_yet(tmp_path):
    first = run_folder(tmp_path, RECIPE[0], 0) / "checkpoints"
    first.mkdir(parents=True)
    (first / "step-000000100.pt").write_bytes(b"")  # its first stage only: not read
    assert release.export_files(tmp_path, SIZES["full"], "release.py") == []
    assert not (tmp_path / "files").exists()


def test_the_ship_rule_names_each_check_that_fails():
    shipped_relit = {"unknown": 0.984, "wood": 1.44, "plastic": 0.982, "metal": 8.74}

    def validation(**default):
        every = {}
        for choice, bar in shipped_relit.items():  # the release at the shipped files' figures
            for name in (choice, SHIPPED + choice):
                every[name] = {"relit_ratio": bar, "albedo_ratio": 0.971, "worst_set": "a",
                               "worst_relit_ratio": 1.0}
        every["unknown"] = every["unknown"] | default
        return {"folds": {"all": every}}

    def procedural(difference, spread):
        return [{"network": "wood", "base_ratio": 0.6, "new_ratio": 0.6 + difference,
                 "paired_difference": difference, "new_ratio_bootstrap_sd": spread}]

    assert ship_rule_failures(validation(), procedural(0.02, 0.03)) == []  # at the bars: ships
    failed = ship_rule_failures(validation(relit_ratio=0.99, albedo_ratio=0.98,
                                           worst_set="godot_marble", worst_relit_ratio=1.2),
                                procedural(0.04, 0.03))
    assert len(failed) == 4
    assert failed[0].startswith("unknown relights the validation at 0.990x")
    assert "albedo is 0.980x" in failed[1] and "godot_marble at 1.200x" in failed[2]
    assert failed[3].startswith("wood on the larger test: 0.640x")
    worse_metal = validation()
    worse_metal["folds"]["all"]["metal"]["relit_ratio"] = 9.0
    assert ship_rule_failures(worse_metal, []) == [
        "metal relights the validation at 9.000x, above the shipped 8.740x"]
    worse_metal["folds"]["all"][SHIPPED + "metal"]["relit_ratio"] = 9.5  # the bar is measured
    assert ship_rule_failures(worse_metal, []) == []


def run_release(work, minutes):
    return subprocess.run([sys.executable, "scripts/release.py", "--out", str(work),
                           "--size", "toy", "--train-minutes", str(minutes)],
                          cwd=REPO, capture_output=True, text=True)


@pytest.mark.slow
@needs_shared
def test_the_release_at_toy_size(tmp_path):
    work = tmp_path / "release"
    stopped = run_release(work, 0)  # no minutes: no run trains, nothing is exported
    assert stopped.returncode == 0, stopped.stderr[-2000:]
    assert "Unfinished" in (work / "card.md").read_text()
    assert not (work / "files").exists()

    done = run_release(work, 60)  # an upper bound: the runs end sooner
    assert done.returncode == 0, done.stderr[-2000:]
    card = (work / "card.md").read_text()
    for network in RECIPE:
        steps = network_steps(network, SIZES["toy"])
        assert f"| {network.name} | {steps} of {steps} |" in card
        for index, stage in enumerate(network.stages):
            # each stage trains on its class's procedural sets of its seeds, and nothing else
            maps = work / "maps" / f"{network.name}-{index + 1}"
            assert {path.resolve() for path in maps.iterdir()} == {
                path.resolve() for seed in stage.seeds
                for path in (work / "sets" / f"{network.name}-{seed}").iterdir()
                if path.is_dir()}
            config = json.loads((run_folder(work, network, index) / "config.json").read_text())
            if index:  # from the export of the stage before
                assert config["init_from"] == str(stage_file(work, network, index - 1))
                assert run_folder(work, network, index).with_suffix(".init").read_text() == \
                    file_digest(stage_file(work, network, index - 1))
            else:
                assert config["init_from"] is None
        path = work / "files" / f"svbrdf-{network.name}.safetensors"
        with safe_open(str(path), framework="pt") as file:
            metadata = file.metadata()
        assert metadata["command"].startswith("scripts/release.py --size toy")
        assert str(tmp_path) not in json.dumps(metadata)  # no machine's paths
        for fold in FOLDS:
            assert f"| {fold} | {network.name} | {SIZES['toy'].photos} |" in card
        assert f"| test | {network.name} | {SIZES['toy'].photos} |" in card
    for fold in (*FOLDS, "test"):  # the estimate for a material of unknown kind
        assert f"| {fold} | unknown | {SIZES['toy'].photos} |" in card
    for choice in CLASSES:  # the ship rule's bars
        for fold in FOLDS:
            assert f"| {fold} | {SHIPPED}{choice} | {SIZES['toy'].photos} |" in card
        assert f"| test | {SHIPPED}{choice} |" not in card  # the test chooses nothing
    procedural = json.loads((work / "release.json").read_text())["procedural"]
    assert [row["network"] for row in procedural] == [network.name for network in RECIPE]
    toy = PROCEDURAL_SIZES["toy"]
    for row in procedural:  # both files on the same photos: each set under its pair's two
        sets = toy.base + toy.pairs * (row["network"] == "wood")  # probes
        assert row["photos"] == 2 * sets
        assert f"| {row['network']} | {row['photos']} | {row['base_ratio']:.3f} |" in card
    failures = json.loads((work / "release.json").read_text())["ship_rule_failures"]
    assert "**Ship rule** (models/README.md): " in card
    assert all(f"- {failure}" in card for failure in failures)

    files = sorted((work / "files").rglob("*.safetensors"))
    before = {path: path.read_bytes() for path in files}
    again = run_release(work, 60)  # all done: nothing is trained or exported again
    assert again.returncode == 0, again.stderr[-2000:]
    assert {path: path.read_bytes() for path in files} == before
