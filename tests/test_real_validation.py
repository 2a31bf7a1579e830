"""scripts/real_validation.py: the real-set splits and the table it writes."""

import json
import sys

import numpy as np

from tests.conftest import REPO, SHARED_DATA, needs_shared

sys.path.insert(0, str(REPO / "scripts"))
from real_validation import (FOLDS, TEST_PROBES, TEST_SETS, VALIDATION_PROBES,  # noqa: E402
                             summarize)


def test_the_splits_are_disjoint():
    sets = [name for names in FOLDS.values() for name in names] + list(TEST_SETS)
    assert len(sets) == len(set(sets))
    assert not set(VALIDATION_PROBES) & set(TEST_PROBES)


@needs_shared
def test_every_shared_set_and_probe_is_in_one_split():
    shared_sets = {p.name for p in (SHARED_DATA / "svbrdfs").iterdir() if p.is_dir()}
    sets = {name for names in FOLDS.values() for name in names} | set(TEST_SETS)
    assert sets == shared_sets
    for probe in VALIDATION_PROBES + TEST_PROBES:
        assert (SHARED_DATA / "probes" / f"{probe}.exr").is_file(), probe


def record(sample, model, naive):
    errors = {"relit_rmse": model, "albedo_rmse": 2 * model}
    return {"sample": sample, "model": errors,
            "naive": {"relit_rmse": naive, "albedo_rmse": 2 * naive}}


def test_the_table_holds_ratios_of_means_per_fold_set_and_over_all(tmp_path):
    results = {"fold1": [record("a_set_000", 1.0, 2.0), record("a_set_001", 3.0, 2.0),
                         record("b_000", 4.0, 1.0)],
               "fold2": [record("c_000", 1.0, 4.0)]}
    for fold, records in results.items():
        folder = tmp_path / fold / "plastic"
        folder.mkdir(parents=True)
        (folder / "results.json").write_text(json.dumps(
            {"samples": len(records), "per_sample": records}))
    table = summarize(tmp_path, ["fold1", "fold2"], ["plastic"])
    assert table["sets"]["a_set"]["plastic"] == 1.0  # (1 + 3) / (2 + 2)
    assert table["sets"]["b"]["plastic"] == 4.0
    row = table["folds"]["fold1"]["plastic"]
    assert np.isclose(row["relit_ratio"], 8.0 / 5.0) and row["worst_set"] == "b"
    assert np.isclose(table["folds"]["all"]["plastic"]["relit_ratio"], 9.0 / 9.0)
    assert "| fold1 | plastic | 3 | 1.60 | 1.60 | b (4.00) |" in (tmp_path / "table.md").read_text()
    assert (tmp_path / "per_set.png").is_file()
