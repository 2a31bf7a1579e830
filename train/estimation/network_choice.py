"""Which SVBRDF-net estimates a photo, and whose specular lobe the estimate keeps.

``sa-estimate`` and ``sa-evaluate`` take the same choices, so that what sa-evaluate measures is
what users get:

- ``--model FILE``: that network for every photo, with the lobe it reads;
- ``--class wood|plastic|metal``: that shipped network for every photo, with the lobe it reads;
- ``--class unknown`` (DEFAULT_CLASS, when nothing is said): a photo of a material of unknown
  kind gets the estimate that relit real materials most safely on the real-set validation
  (models/README.md): the plastic network's albedo and normals with the fixed lobe,
  FIXED_SPECULAR and FIXED_ROUGHNESS (the naive baseline's). There the plastic network's own
  lobe reading relit no better on the mean (0.982x against 0.984x the naive baseline's) and up
  to 1.74x on single sets (ambientcg_Onyx003), where the fixed lobe stays at or below 1.10x
  (docs/experiments/2026-12-05-fixed-lobe-default.md).

A choice (FixedNetwork) has ``input_size`` (the photo side its network takes),
``for_photo(photo)``, which returns the network for a (3, S, S) photo and a dict saying which
one (``model``: its file) and whose lobe (``lobe``: ``read`` or ``fixed``), ``fixed_lobe``
(whether the estimate's lobe is the fixed one) and ``model_files``, the files its estimates
depend on (what a resumed batch compares, train.estimation.batch). The shipped material
classifier that picked a class network per photo (``--class auto``) was removed on 2026-12-04:
on the real-set validation its picks relit 1.57x worse than the naive baseline
(docs/experiments/2026-12-04-material-classifier-removed.md).
"""

from pathlib import Path

import numpy as np

from train.networks.model_files import SHIPPED, load_network, shipped_model_path
from train.networks.svbrdf_net import SVBRDFNet

UNKNOWN = "unknown"
CLASSES = (UNKNOWN, *SHIPPED)
"""The --class choices."""
DEFAULT_CLASS = UNKNOWN
UNKNOWN_MATERIAL_NETWORK = "plastic"
"""The shipped network whose maps a photo of unknown material gets: of the shipped networks,
the one that relit real materials best on the real-set validation. Its photo-affine albedo is
the photo less a grey offset, so it keeps the photo's colour and detail on any material."""
FIXED_SPECULAR = 0.08
"""Relative specular albedo (every RGB channel) of the fixed lobe, the naive baseline's."""
FIXED_ROUGHNESS = 0.25
"""Ward alpha of the fixed lobe, the naive baseline's."""


class FixedNetwork:
    """One network for every photo; the lobe it reads, or the fixed one."""

    def __init__(self, net: SVBRDFNet, fixed_lobe: bool = False):
        self.net = net
        self.fixed_lobe = fixed_lobe
        self.input_size = net.config.input_size

    @property
    def model_files(self) -> list[Path]:
        return [Path(self.net.source)]

    def for_photo(self, photo: np.ndarray) -> tuple[SVBRDFNet, dict]:
        return self.net, {"model": self.net.source,
                          "lobe": "fixed" if self.fixed_lobe else "read"}


def class_model_file(material_class: str, models: Path | None = None) -> Path:
    """The file ``--class material_class`` (one of CLASSES) estimates with:
    svbrdf-<network>.safetensors in the folder ``models`` (None: the shipped models)."""
    name = UNKNOWN_MATERIAL_NETWORK if material_class == UNKNOWN else material_class
    return shipped_model_path(name) if models is None else models / f"svbrdf-{name}.safetensors"


def network_choice(model: str | Path | None, material_class: str, device: str = "cpu",
                   models: Path | None = None) -> FixedNetwork:
    """The choice of the command line: ``model`` (a file or run folder) if given, else the
    choice of ``material_class`` (one of CLASSES; the module docstring) among the files of
    ``models`` (None: the shipped models; a release measures its own)."""
    if model is not None:
        return FixedNetwork(load_network(model, device))
    return FixedNetwork(load_network(class_model_file(material_class, models), device),
                        fixed_lobe=material_class == UNKNOWN)
