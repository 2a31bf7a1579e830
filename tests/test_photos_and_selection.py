"""Photos as network input (linearization, crop, resize, bad files) and the color-matched
unlabeled subset."""

import numpy as np
import pytest

from render.common.errors import InputError
from render.common.images import write_exr
from tests.conftest import write_png
from train.data.photos import read_photo
from train.data.unlabeled_selection import color_bins, select_matching


def test_ldr_photo_is_linearized_cropped_and_resized(tmp_path):
    pixels = np.full((40, 60, 3), 0.5, np.float32)
    pixels[:, :10] = 1.0  # outside the centred 40 x 40 square
    write_png(tmp_path / "photo.png", pixels)
    photo = read_photo(tmp_path / "photo.png", 20)
    assert photo.shape == (3, 20, 20) and photo.dtype == np.float32
    expected = (round(0.5 * 255) / 255) ** 2.2
    assert np.allclose(photo, expected, atol=1e-5)


def test_hdr_photo_is_auto_exposed(tmp_path):
    write_exr(tmp_path / "photo.exr", np.full((32, 32, 3), 250.0, np.float32))
    assert np.allclose(read_photo(tmp_path / "photo.exr", 16), 0.18, atol=1e-5)


def test_bad_photos_get_clear_errors(tmp_path):
    (tmp_path / "notes.png").write_text("not an image")
    with pytest.raises(InputError, match="notes.png"):
        read_photo(tmp_path / "notes.png", 16)
    write_png(tmp_path / "tiny.png", np.zeros((8, 8, 3), np.float32))
    with pytest.raises(InputError, match="tiny.png.*at least"):
        read_photo(tmp_path / "tiny.png", 16)
    bad = np.ones((32, 32, 3), np.float32)
    bad[3, 3] = np.nan
    write_exr(tmp_path / "nan.exr", bad)
    with pytest.raises(InputError, match="nan.exr.*NaN"):
        read_photo(tmp_path / "nan.exr", 16)


def test_selection_follows_the_labeled_color_histogram():
    rng = np.random.default_rng(0)
    labeled = np.concatenate([np.full((30, 3), 0.1), np.full((10, 3), 0.6)])
    dark, mid, bright = np.full((200, 3), 0.1), np.full((20, 3), 0.6), np.full((50, 3), 0.9)
    unlabeled = np.concatenate([dark, mid, bright])
    chosen = select_matching(labeled, unlabeled, rng)
    bins = color_bins(unlabeled[chosen], 4)
    assert len(chosen) == len(set(chosen.tolist())) == 80  # the 20 mid photos allow 80 in all
    assert (bins == color_bins(dark[:1], 4)[0]).sum() == 60
    assert (bins == color_bins(mid[:1], 4)[0]).sum() == 20
    assert not (bins == color_bins(bright[:1], 4)[0]).any()
    assert len(select_matching(labeled, unlabeled, rng, limit=8)) == 8
    with pytest.raises(ValueError, match="no unlabeled photo"):
        select_matching(labeled, bright, rng)
