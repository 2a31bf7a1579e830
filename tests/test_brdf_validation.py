"""sa-validate: the search space, the sphere tables against direct renders, and the pipeline
end to end at toy size."""

import json

import numpy as np
import pytest
import torch
from click.testing import CliRunner

from render.common.color import REC709_LUMINANCE
from render.common.exposure import expose
from render.common.probes import find_probes, load_probe
from render.torch_renderer.renderer import ProbeBank, render, sphere_normals
from tests.conftest import BUNDLED_PROBES
from train.brdf_validation import search_space
from train.brdf_validation.validation import (
    CONFIGURATIONS,
    SphereRenderer,
    ValidationConfig,
    from_targets,
    make_renderer,
    ratio_table,
)
from train.cli.sa_validate import main


def test_search_space_and_patterns():
    train, test = search_space.training_brdfs(), search_space.test_brdfs()
    assert train.shape == (1500, 3) and test.shape == (9 * 9 * 14, 3)
    assert np.isclose(train[:, 2].min(), 0.02) and np.isclose(train[:, 0].max(), 1.0)
    assert not (set(map(tuple, test.round(6))) & set(map(tuple, train.round(6))))
    counts = {p: search_space.labeled_mask(p).sum() for p in
              ("dense", "5x5x7", "3x3x5", "2x2x2", "random-12.5", "random-3.7")}
    assert counts == {"dense": 1500, "5x5x7": 175, "3x3x5": 45, "2x2x2": 8,
                      "random-12.5": 188, "random-3.7": 56}
    corners = train[search_space.labeled_mask("2x2x2")]
    assert set(np.round(corners[:, 2], 6)) == {0.02, 1.0}  # the extremes of each axis
    with pytest.raises(ValueError, match="unknown sampling pattern"):
        search_space.labeled_mask("half")
    round_trip = from_targets(search_space.targets(train))
    assert np.allclose(round_trip[:, 0] / round_trip[:, 1], train[:, 0] / train[:, 1])
    assert np.allclose(round_trip[:, 2], train[:, 2])


def test_sphere_tables_match_direct_renders():
    files = find_probes(BUNDLED_PROBES)
    lightings = np.array([[0, 30.0], [2, 200.0], [0, 275.0]])  # probe 0 twice: one strip
    levels = np.geomspace(0.1, 1.0, 5)  # broad levels only: the sharp ones cost seconds each
    renderer = SphereRenderer(files, 16, lightings, "cpu", levels)
    gray = [np.repeat(r @ REC709_LUMINANCE, 3).reshape(r.shape)
            for r in (load_probe(p).radiance for p in files)]
    normal, mask = sphere_normals(16)
    brdfs = np.array([[0.3, 0.7, levels[2]],  # on a table level: exact
                      [0.8, 0.2, np.sqrt(levels[3] * levels[4])]])  # interpolated
    for brdf in brdfs:
        for k, (probe, rotation) in enumerate(lightings):
            direct = render((torch.full((1, 3, 16, 16), brdf[0]) * mask),
                            normal[None], torch.full((1, 3), brdf[1]),
                            torch.tensor([brdf[2]], dtype=torch.float32), ProbeBank(gray),
                            [int(probe)], torch.tensor([rotation], dtype=torch.float32))
            expected = expose(direct * mask)[:, :1]
            table = renderer(brdf[None], [k])
            assert torch.abs(table - expected).max() < 0.02, (brdf, k)


def test_pipeline_end_to_end_at_toy_size(tmp_path):
    result = CliRunner().invoke(main, ["--probes", str(BUNDLED_PROBES), "--out",
                                       str(tmp_path / "val"), "--config", "toy",
                                       "--patterns", "2x2x2"])
    assert result.exit_code == 0, result.output
    for name in ("table.csv", "table.md", "heat_maps.png", "results.json", "config.json"):
        assert (tmp_path / "val" / name).is_file(), name
    table = (tmp_path / "val" / "table.md").read_text()
    assert "| 2x2x2 | 8 |" in table and "| dense | 1500 |" in table

    # Resume: a run lost (as if killed during it) is redone to the same result, the others are
    # read back; the folder may move; another seed is refused.
    results = json.loads((tmp_path / "val" / "results.json").read_text())
    assert sorted(p.name for p in (tmp_path / "val" / "runs").iterdir()) == [
        "2x2x2.json", "2x2x2_SA.json", "dense.json"]
    (tmp_path / "val" / "runs" / "2x2x2_SA.json").unlink()
    (tmp_path / "val").rename(tmp_path / "moved")
    again = CliRunner().invoke(main, ["--probes", str(BUNDLED_PROBES), "--out",
                                      str(tmp_path / "moved"), "--config", "toy",
                                      "--patterns", "2x2x2"])
    assert again.exit_code == 0, again.output
    resumed = json.loads((tmp_path / "moved" / "results.json").read_text())
    for key, result in results.items():
        assert {k: v for k, v in resumed[key].items() if k != "seconds"} == \
            {k: v for k, v in result.items() if k != "seconds"}, key
    other = CliRunner().invoke(main, ["--probes", str(BUNDLED_PROBES), "--out",
                                      str(tmp_path / "moved"), "--config", "toy",
                                      "--patterns", "2x2x2", "--seed", "1"])
    assert other.exit_code != 0 and "(differing: seed)" in other.output


def test_ratio_table_at_toy_size(tmp_path):
    labeled, unlabeled = search_space.random_split(20, 50, seed=3)
    assert labeled.sum() == 300 and unlabeled.sum() == 750 and not (labeled & unlabeled).any()
    with pytest.raises(ValueError, match="more than 100"):
        search_space.random_split(60, 50)
    cfg = ValidationConfig(probes=str(BUNDLED_PROBES), out=str(tmp_path),
                           **CONFIGURATIONS["toy"])
    table = ratio_table(cfg, make_renderer(cfg), (50, 100), (20, 50))
    assert list(table[50]) == ["no SA", 20, 50] and list(table[100]) == ["no SA"]
    assert all(np.isfinite(v) and v >= 0 for row in table.values() for v in row.values())
    text = (tmp_path / "ratio_table.md").read_text()
    assert "| percent labeled | no SA | 20% unlabeled | 50% unlabeled |" in text
    assert (tmp_path / "ratio_table.csv").is_file()
