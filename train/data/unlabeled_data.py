"""Unlabeled training images: a folder of photos, or a dataset folder whose labels are ignored.

Photos are read by train.data.photos.read_photo (its rule: linearized, centre square, resized to the
network's input size); a ``render-dataset`` output (a folder with ``index.json``) gives the
images of all its samples, which must already have the input size.
"""

from pathlib import Path

import numpy as np

from render.common.errors import InputError
from render.common.images import IMAGE_SUFFIXES
from train.data.labeled_dataset import LabeledDataset
from train.data.photos import read_photo


class UnlabeledImages:
    """(3, size, size) linear RGB network inputs, by index."""

    def __init__(self, folder: str | Path, size: int):
        self.folder, self.size = Path(folder), size
        if not self.folder.is_dir():
            raise InputError(self.folder, "unlabeled folder not found")
        if (self.folder / "index.json").is_file():
            self.dataset = LabeledDataset(self.folder, split=None)
            self.paths = None
            count = len(self.dataset)
        else:
            self.dataset = None
            self.paths = sorted(p for p in self.folder.rglob("*")
                                if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES)
            count = len(self.paths)
        if count == 0:
            raise InputError(self.folder, "no unlabeled images (photos or a dataset) found")

    def __len__(self):
        return len(self.paths) if self.dataset is None else len(self.dataset)

    def image(self, index: int) -> np.ndarray:
        if self.dataset is None:
            return read_photo(self.paths[index], self.size)
        image = self.dataset[index]["image"]
        if image.shape[1:] != (self.size, self.size):
            raise InputError(self.folder, f"dataset images are {image.shape[2]}x{image.shape[1]}"
                                          f"; the network takes {self.size}x{self.size}")
        return image

    def average_colors(self) -> np.ndarray:
        """(N, 3) mean linear RGB of every image."""
        return np.stack([self.image(i).mean((1, 2)) for i in range(len(self))])
