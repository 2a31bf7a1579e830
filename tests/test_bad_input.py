"""Bad input: one clear error naming the file, raised before any rendering starts."""

import logging

import numpy as np
import pytest
from click.testing import CliRunner

from render.cli.render_dataset import main
from render.common.errors import InputError
from render.common.probes import load_probe
from render.materials.reduced_svbrdf import load_material
from tests.conftest import BUNDLED_MATERIALS, BUNDLED_PROBES, make_material, make_probe


def sky(height=16):
    return np.ones((height, 2 * height, 3), np.float32)


def test_corrupt_and_truncated_images(tmp_path):
    folder = make_material(tmp_path / "m", np.full((8, 8, 3), 0.5))
    data = (folder / "m_albedo.png").read_bytes()
    (folder / "m_albedo.png").write_bytes(data[: len(data) // 2])
    with pytest.raises(InputError, match="m_albedo.png: cannot decode image"):
        load_material(folder)
    probe = tmp_path / "p.exr"
    probe.write_bytes(b"not an exr at all")
    with pytest.raises(InputError, match="p.exr: cannot read OpenEXR"):
        load_probe(probe)


def test_folder_without_albedo(tmp_path):
    folder = make_material(tmp_path / "m", np.full((8, 8, 3), 0.5), normal=np.full((8, 8, 3), 0.5))
    (folder / "m_albedo.png").unlink()
    with pytest.raises(InputError, match="no albedo map recognized"):
        load_material(folder)


def test_empty_folder(tmp_path):
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError, match="empty: empty material folder"):
        load_material(tmp_path / "empty")


def test_maps_of_mismatched_sizes(tmp_path):
    folder = make_material(tmp_path / "m", np.full((8, 8, 3), 0.5), roughness=np.ones((4, 4)))
    with pytest.raises(InputError, match=r"m_roughness.png: roughness map is 4x4 .* 8x8"):
        load_material(folder)


def test_grayscale_normal_map(tmp_path):
    folder = make_material(tmp_path / "m", np.full((8, 8, 3), 0.5), normal=np.full((8, 8), 0.5))
    with pytest.raises(InputError, match="m_normal.png: normal map must be RGB"):
        load_material(folder)


@pytest.mark.parametrize("radiance, message", [
    (np.where(np.arange(16)[:, None, None] == 3, np.nan, sky()), "NaN or Inf"),
    (np.full((16, 16, 3), 1.0), r"not a 2:1 equirectangular probe \(16x16"),
    (np.ones((16, 32, 1)), "grayscale probe"),
    (sky() * -1, "negative radiance"),
    (np.concatenate([np.zeros((9, 32, 3)), np.ones((7, 32, 3))]), "no light above the horizon"),
])
def test_bad_probes(tmp_path, radiance, message):
    path = make_probe(tmp_path / "bad.exr", radiance[..., 0] if radiance.shape[2] == 1
                      else radiance)
    with pytest.raises(InputError, match=f"bad.exr: .*{message}"):
        load_probe(path)


def test_slightly_negative_probe_is_clamped_with_a_warning(tmp_path, caplog):
    radiance = sky()
    radiance[2, 3] = -0.001
    with caplog.at_level(logging.WARNING):
        probe = load_probe(make_probe(tmp_path / "p.exr", radiance))
    assert probe.radiance.min() >= 0
    assert "clamped 3 slightly negative" in caplog.text


def test_radiance_hdr_probe(tmp_path, mi):
    path = tmp_path / "p.hdr"
    mi.Bitmap(sky() * np.array([1.0, 2.0, 3.0], np.float32)).write(str(path))
    probe = load_probe(path)
    np.testing.assert_allclose(probe.white_balance[0] / probe.white_balance[2], 3.0, rtol=0.02)


def test_cli_fails_before_rendering_and_names_the_file(tmp_path):
    probes = tmp_path / "probes"
    probes.mkdir()
    make_probe(probes / "good.exr", sky())
    make_probe(probes / "zz_broken.exr", sky()[:, :20])
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["--probes", str(probes), "--svbrdfs",
                                       str(BUNDLED_MATERIALS), "--out", str(out)])
    assert result.exit_code == 1
    assert "zz_broken.exr: not a 2:1 equirectangular probe" in result.output
    assert not out.exists()


def test_cli_rejects_folder_without_materials(tmp_path):
    (tmp_path / "none").mkdir()
    result = CliRunner().invoke(main, ["--probes", str(BUNDLED_PROBES), "--svbrdfs",
                                       str(tmp_path / "none"), "--out", str(tmp_path / "o")])
    assert result.exit_code == 1 and "no material sub-folders" in result.output
