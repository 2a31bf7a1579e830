"""scripts/compare_evaluations.py: two sa-evaluate runs compared photo by photo."""

import importlib.util
import json
import math

from click.testing import CliRunner

from tests.conftest import REPO

_spec = importlib.util.spec_from_file_location("compare_evaluations",
                                               REPO / "scripts" / "compare_evaluations.py")
comparison = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(comparison)


def results_file(path, errors):
    """An sa-evaluate results.json at ``path`` of {sample: (model relit, naive relit)}."""
    per_sample = [{"sample": name, "model": {"relit_rmse": model},
                   "naive": {"relit_rmse": naive}} for name, (model, naive) in errors.items()]
    path.write_text(json.dumps({"mean": {}, "per_sample": per_sample}))
    return path


BASE = {"wood_s1_0000_000": (0.02, 0.04), "wood_s1_0000_001": (0.04, 0.04),
        "wood_s1_0001_000": (0.03, 0.02)}
NEW = {"wood_s1_0000_000": (0.01, 0.04), "wood_s1_0000_001": (0.05, 0.04),
       "wood_s1_0001_000": (0.00, 0.02)}


def test_ratios_and_the_paired_difference_match_a_hand_computed_case():
    """Naive mean 0.1 / 3; base 0.09 / 3 -> 0.9, new 0.06 / 3 -> 0.6; differences over the naive
    mean -0.3, +0.3, -0.9 (mean -0.3, sample sd 0.6, so SE 0.6 / sqrt 3); new better on 2 of 3."""
    report = comparison.compare(BASE, NEW, draws=200, seed=0)
    assert report["photos"] == 3 and report["sets"] == 2
    assert math.isclose(report["base_ratio"], 0.9, rel_tol=1e-9)
    assert math.isclose(report["new_ratio"], 0.6, rel_tol=1e-9)
    assert math.isclose(report["paired_difference"], -0.3, rel_tol=1e-9)
    assert math.isclose(report["standard_error"], 0.6 / math.sqrt(3), rel_tol=1e-9)
    assert math.isclose(report["new_better_share"], 2 / 3)


def test_the_bootstrap_draws_whole_sets():
    """Two sets drawn with replacement: set 0 twice gives 0.12 / 0.16 = 0.75, set 1 twice
    0.0, one of each 0.06 / 0.10 = 0.6, so every quantile is one of them (photos drawn one by
    one would give other ratios)."""
    report = comparison.compare(BASE, NEW, draws=400, seed=1)
    for quantile in report["new_ratio_bootstrap_5_95"]:
        assert min(abs(quantile - value) for value in (0.0, 0.6, 0.75)) < 1e-9


def test_the_set_of_a_sample_is_read_from_either_kind_of_name():
    assert comparison.material_set("wood_s1_0003__circus_arena__r00_c00") == "wood_s1_0003"
    assert comparison.material_set("materialx_wood__env-lab__r00_c00") == "materialx_wood"
    assert comparison.material_set("wood_s12_0052_000") == "wood_s12_0052"


def test_runs_of_other_photos_are_refused_with_one_line(tmp_path):
    base = results_file(tmp_path / "base.json", BASE)
    other = results_file(tmp_path / "other.json", NEW | {"wood_s1_0002_000": (0.1, 0.1)})
    relit = results_file(tmp_path / "relit.json", {name: (model, 2 * naive) for name,
                                                     (model, naive) in NEW.items()})
    for path, problem in ((other, "holds other samples"), (relit, "naive baseline's errors")):
        result = CliRunner().invoke(comparison.main, [str(base), str(path)])
        assert result.exit_code != 0
        assert problem in result.output and str(path) in result.output
        assert len(result.output.strip().splitlines()) == 1


def test_a_file_that_is_not_a_results_file_is_named(tmp_path):
    broken = tmp_path / "broken.json"
    broken.write_text("{not json")
    result = CliRunner().invoke(comparison.main, [str(broken), str(broken)])
    assert result.exit_code != 0 and str(broken) in result.output
    assert len(result.output.strip().splitlines()) == 1
