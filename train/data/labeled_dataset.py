"""Reading a ``render-dataset`` folder as a map-style dataset (usable by torch's DataLoader).

Each item is a dict of numpy arrays in the layout of docs/dataset-format.md, converted to
float32 and channel-first: image, albedo, normal (3, H, W); log_specular (3,);
log_roughness (1,); plus the sample's provenance dict.
"""

import json
from pathlib import Path

import numpy as np

from render.common.errors import InputError, require_folder

ARRAYS = ("image", "albedo", "normal", "log_specular", "log_roughness")


class LabeledDataset:
    """Samples of one split ('train', 'test' or None for all) of a dataset folder."""

    def __init__(self, folder: str | Path, split: str | None = "train"):
        self.folder = require_folder(folder, "dataset folder")
        index_path = self.folder / "index.json"
        if not index_path.is_file():
            raise InputError(self.folder, "no index.json (not a finished render-dataset output "
                                          "folder)")
        try:
            samples = json.loads(index_path.read_text())["samples"]
        except (UnicodeDecodeError, json.JSONDecodeError, KeyError, TypeError) as error:
            raise InputError(index_path, f"cannot read the dataset index ({type(error).__name__}"
                                         f": {error})") from None
        self.samples = [s for s in samples if split is None or s["split"] == split]

    def __len__(self):
        return len(self.samples)

    def __getitem__(self, i):
        record = self.samples[i]
        with np.load(self.folder / record["file"]) as data:
            item = {name: data[name].astype(np.float32) for name in ARRAYS}
        for name in ("image", "albedo", "normal"):
            item[name] = np.ascontiguousarray(item[name].transpose(2, 0, 1))  # (3, H, W)
        item["provenance"] = record
        return item
