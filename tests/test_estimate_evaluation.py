"""sa-evaluate's metrics against hand-computed cases, labeled maps rendered on the fly, and
model files that never execute code; sa-estimate with the shipped models."""

import json
import math
import pickle
from pathlib import Path

import numpy as np
import pytest
import torch
from click.testing import CliRunner
from safetensors import safe_open
from safetensors.torch import load_file, save_file

from render.common.errors import InputError
from render.common.exposure import expose
from render.common.probes import find_probes, load_probe
from render.torch_renderer.renderer import ProbeBank
from tests.conftest import (
    BUNDLED_MATERIALS,
    BUNDLED_PHOTO,
    BUNDLED_PROBES,
    estimate_bundled_photo,
)
from train.cli.sa_estimate import main as sa_estimate
from train.cli.sa_evaluate import main as sa_evaluate
from train.data.map_samples import MapSampler
from train.estimation.network_choice import FIXED_ROUGHNESS, FIXED_SPECULAR
from train.evaluation.estimate_evaluation import (
    ERRORS,
    SWAPS,
    naive_estimate,
    relit_rmse,
    relit_under,
    sample_errors,
    summary,
)
from train.networks.checkpoints import FORMAT as CHECKPOINT_FORMAT
from train.networks.model_files import FORMAT as MODEL_FORMAT
from train.networks.model_files import (
    SHIPPED,
    load_network,
    model_metadata,
    save_model,
    shipped_model_path,
)
from train.networks.svbrdf_net import NetworkConfig, SVBRDFNet

TINY = NetworkConfig(input_size=32, width=4, max_width=16, levels=3, hidden=32)


def parameters(albedo=0.5, normal=(0.0, 0.0, 1.0), specular=0.08, roughness=0.25, size=8):
    normal = torch.nn.functional.normalize(torch.tensor(normal, dtype=torch.float32), dim=0)
    return {"albedo": torch.full((1, 3, size, size), float(albedo)),
            "normal": normal[None, :, None, None].expand(1, 3, size, size).clone(),
            "log_specular": torch.full((1, 3), math.log(specular)),
            "log_roughness": torch.tensor([[math.log(roughness)]])}


def test_a_perfect_estimate_scores_zero():
    truth = parameters(albedo=0.7, normal=(0.2, -0.1, 1.0), specular=0.3, roughness=0.1)
    relit = torch.rand(3, 3, 8, 8)
    errors = sample_errors(truth, truth, relit, relit)
    assert errors == pytest.approx({name: 0.0 for name in errors}, abs=1e-3)


def test_errors_match_hand_computed_values():
    truth = parameters(albedo=0.5, normal=(0.0, 0.0, 1.0), specular=0.08, roughness=0.25)
    tilt = math.radians(30.0)
    guess = parameters(albedo=0.8, normal=(math.sin(tilt), 0.0, math.cos(tilt)), specular=0.16,
                       roughness=0.05)
    relit_truth = torch.zeros(2, 3, 8, 8)
    errors = sample_errors(guess, truth, relit_truth + 0.1, relit_truth)
    assert errors["albedo_rmse"] == pytest.approx(0.3, abs=1e-6)
    assert errors["normal_angle_deg"] == pytest.approx(30.0, abs=0.05)
    assert errors["log_specular_error"] == pytest.approx(math.log(2.0), abs=1e-6)
    assert errors["log_roughness_error"] == pytest.approx(math.log(5.0), abs=1e-6)
    assert errors["relit_rmse"] == pytest.approx(0.1, abs=1e-6)


def test_the_naive_baseline_is_the_scaled_photo_flat_and_fixed_specular():
    photo = np.random.default_rng(0).uniform(0.05, 0.6, size=(3, 16, 16)).astype(np.float32)
    naive = naive_estimate(photo)
    assert float(naive["albedo"].mean()) == pytest.approx(0.5, abs=1e-5)
    assert torch.allclose(naive["albedo"][0], torch.as_tensor(photo) * (0.5 / photo.mean()),
                          atol=1e-5)
    assert torch.equal(naive["normal"][0, 2], torch.ones(16, 16))
    assert torch.allclose(naive["log_specular"], torch.full((1, 3), math.log(FIXED_SPECULAR)))
    assert float(naive["log_roughness"]) == pytest.approx(math.log(FIXED_ROUGHNESS))
    # scored against itself as the truth, the baseline's errors vanish; the ratio divides means
    swapped = {swap: 0.01 for swap in SWAPS}
    records = [{"model": sample_errors(naive, naive, torch.zeros(1), torch.zeros(1))
                | {"relit_with_true": swapped},
                "naive": {"albedo_rmse": 0.2, "normal_angle_deg": 4.0,
                          "log_specular_error": 1.0, "log_roughness_error": 0.5,
                          "relit_rmse": 0.05, "relit_with_true": swapped}}]
    mean = summary(records)
    assert mean["ratio"]["relit_rmse"] == pytest.approx(0.0, abs=1e-6)
    assert mean["naive"]["normal_angle_deg"] == 4.0
    assert mean["naive"]["relit_with_true"] == swapped


@pytest.fixture(scope="module")
def bank():
    return ProbeBank([load_probe(path).radiance for path in find_probes(BUNDLED_PROBES)])


def test_swapping_the_truth_into_the_wrong_part_removes_the_relit_error(bank):
    truth = parameters(albedo=0.4, normal=(0.1, 0.2, 1.0), specular=0.05, roughness=0.1)
    wrong_specular = truth | {"log_specular": torch.full((1, 3), math.log(0.5))}
    probe_index, rotation = torch.tensor([0, 1]), torch.tensor([30.0, 200.0])
    truth_hdr = relit_under(truth, bank, probe_index, rotation)
    relit_truth = expose(truth_hdr)

    def with_true(names):
        return relit_rmse(wrong_specular | {name: truth[name] for name in names}, bank,
                          probe_index, rotation, truth_hdr, relit_truth)

    unswapped = relit_rmse(wrong_specular, bank, probe_index, rotation, truth_hdr, relit_truth)
    assert unswapped > 0.01  # a specular albedo 10x too bright shows when relit
    assert with_true(SWAPS["specular"]) == pytest.approx(0.0, abs=1e-6)
    assert with_true(SWAPS["specular+roughness"]) == pytest.approx(0.0, abs=1e-6)
    for right_already in ("albedo", "normals", "roughness"):
        assert with_true(SWAPS[right_already]) == pytest.approx(unswapped, rel=1e-6)


def test_labeled_maps_give_valid_reproducible_samples_and_shards(bank):
    sampler = MapSampler(BUNDLED_MATERIALS, bank, [0, 1], size=16, render_size=32)
    batch = sampler.batch(np.random.default_rng(3), 4)
    assert batch["image"].shape == batch["albedo"].shape == (4, 3, 16, 16)
    assert 0 <= float(batch["image"].min()) and float(batch["image"].max()) <= 1
    assert batch["albedo"].mean((1, 2, 3)) == pytest.approx(torch.full((4,), 0.5), abs=1e-4)
    assert torch.allclose(batch["normal"].norm(dim=1), torch.ones(4, 16, 16), atol=1e-4)
    assert {p["probe_index"] for p in batch["provenance"]} <= {0, 1}
    again = sampler.batch(np.random.default_rng(3), 4)
    assert torch.equal(batch["image"], again["image"])
    second_half = sampler.batch(np.random.default_rng(3), 4, lambda items: items[2:])
    assert torch.allclose(second_half["image"], batch["image"][2:], atol=1e-6)


def test_sa_evaluate_reports_model_naive_and_ratio(tmp_path):
    torch.manual_seed(0)
    model = tmp_path / "tiny.safetensors"
    save_model(SVBRDFNet(TINY), model, {"class": "test"})
    result = CliRunner().invoke(sa_evaluate, [
        "--model", str(model), "--materials", str(BUNDLED_MATERIALS), "--probes",
        str(BUNDLED_PROBES), "--out", str(tmp_path / "eval"), "--samples", "2",
        "--sample-size", "32", "--relights", "2"])
    assert result.exit_code == 0, result.output
    report = json.loads(result.stdout)
    assert report["samples"] == 2 and "per_sample" not in report
    for kind in ("model", "naive", "ratio"):
        assert all(np.isfinite(report["mean"][kind][name]) for name in ERRORS), kind
    for kind in ("model", "naive"):
        swapped = report["mean"][kind]["relit_with_true"]
        assert set(swapped) == set(SWAPS) and all(np.isfinite(v) for v in swapped.values())
    full = json.loads((tmp_path / "eval" / "results.json").read_text())
    assert len(full["per_sample"]) == 2
    assert all(len(r["relight_probes"]) == 2 and r["photo_probe"] not in r["relight_probes"]
               for r in full["per_sample"])
    assert (tmp_path / "eval" / "figure.png").stat().st_size > 0


class Payload:
    """Unpickling this runs ``Path.touch`` on the marker: the code a crafted file carries."""

    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return Path.touch, (self.marker,)


def test_a_checkpoint_carrying_code_is_refused_without_running_it(tmp_path):
    marker = tmp_path / "code-ran"
    crafted = tmp_path / "crafted.pt"
    torch.save({"format": CHECKPOINT_FORMAT, "model": Payload(marker)}, crafted)
    with pytest.raises(InputError, match="crafted.pt: cannot read checkpoint safely"):
        load_network(crafted)
    assert not marker.exists()
    pickle.loads(pickle.dumps(Payload(marker)))  # the payload is live: plain pickle runs it
    assert marker.exists()


def write_foreign(path):
    save_file({"w": torch.zeros(2)}, str(path))


def write_corrupt(path):
    path.write_bytes(b"\x10\x00\x00\x00\x00\x00\x00\x00{not json")


def write_with_a_removed_head(path):
    """A model file of before 2026-12-05, whose network carried a joint reading head."""
    save_model(SVBRDFNet(TINY), path, {"class": "plastic"})
    tensors = load_file(str(path))
    with safe_open(str(path), framework="pt") as file:
        metadata = file.metadata()
    network = json.loads(metadata["network"]) | {"joint_reading": True}
    save_file(tensors, str(path), metadata=metadata | {"network": json.dumps(network)})


def write_without_the_normal_network(path):
    net = SVBRDFNet(TINY)
    save_model(net, path, {"class": "plastic"})
    with safe_open(str(path), framework="pt") as file:
        metadata = file.metadata()
    save_file({name: value for name, value in load_file(str(path)).items()
               if not name.startswith("normal.")}, str(path), metadata=metadata)


@pytest.mark.parametrize("write, message", [
    (write_foreign, "not an sa-svbrdf model"), (write_corrupt, "cannot read safetensors"),
    (write_with_a_removed_head, "model has no valid network configuration .*joint_reading"),
    (write_without_the_normal_network,
     "weights do not fit this network architecture \\(missing normal.analysis")])
def test_foreign_and_corrupt_model_files_get_one_line_errors(tmp_path, write, message):
    path = tmp_path / "model.safetensors"
    write(path)
    with pytest.raises(InputError, match=f"model.safetensors: {message}"):
        load_network(path)


def test_an_unknown_class_is_refused():
    with pytest.raises(ValueError, match="unknown model class 'stone'"):
        shipped_model_path("stone")


def test_a_model_file_round_trips_in_float16(tmp_path):
    torch.manual_seed(1)
    net = SVBRDFNet(TINY).eval()
    save_model(net, tmp_path / "m.safetensors", {"class": "wood"})
    assert (tmp_path / "m.safetensors").stat().st_mode & 0o777 == 0o644
    loaded = load_network(tmp_path / "m.safetensors")
    image = torch.rand(2, 3, 32, 32)
    with torch.no_grad():
        before, after = net(image), loaded(image)
    for name in before:
        assert torch.allclose(before[name], after[name], atol=2e-2, rtol=1e-2), name


def test_metadata_copied_from_another_file_keeps_the_new_files_format_and_network(tmp_path):
    """A model written with the metadata of another file (a variant of a shipped file) has its
    own format and network configuration, the rest copied."""
    small = NetworkConfig(input_size=32, width=4, max_width=8, levels=3, hidden=16)
    save_model(SVBRDFNet(small), tmp_path / "old.safetensors", {"class": "plastic"})
    copied = model_metadata(tmp_path / "old.safetensors", MODEL_FORMAT, "model")
    save_model(SVBRDFNet(TINY), tmp_path / "new.safetensors",
               copied | {"format": "another format"})
    metadata = model_metadata(tmp_path / "new.safetensors", MODEL_FORMAT, "model")
    assert metadata["class"] == "plastic"
    assert load_network(tmp_path / "new.safetensors").config == TINY


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_models_load_and_fit_the_size_limit(name):
    path = shipped_model_path(name)
    assert path.stat().st_size <= 15 * 10 ** 6
    net = load_network(path)
    assert net.config.input_size == 256


def test_sa_estimate_with_a_class_uses_that_shipped_network(tmp_path):
    photo = BUNDLED_PHOTO
    report, material = estimate_bundled_photo(tmp_path / "est", "--class", "metal")
    assert report["model"].endswith("svbrdf-metal.safetensors")
    assert 0.02 <= material["ward_roughness"] <= 1.0
    result = CliRunner().invoke(sa_estimate, [str(photo), "--class", "wood", "--out",
                                              str(tmp_path / "wood")])
    assert result.exit_code == 0, result.output


def test_a_folder_that_is_not_a_dataset_gets_a_one_line_error(tmp_path):
    (tmp_path / "photos").mkdir()
    result = CliRunner().invoke(sa_evaluate, [
        "--class", "wood", "--dataset", str(tmp_path / "photos"), "--probes",
        str(BUNDLED_PROBES), "--out", str(tmp_path / "eval")])
    assert result.exit_code == 1  # a ClickException, not an uncaught error
    assert f"{tmp_path / 'photos'}: no index.json" in result.output
    assert "Traceback" not in result.output and not (tmp_path / "eval").exists()
