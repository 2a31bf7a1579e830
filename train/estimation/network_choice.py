"""Which SVBRDF-net estimates a photo.

``sa-estimate`` and ``sa-evaluate`` take the same choices, so that what sa-evaluate measures is
what users get:

- ``--model FILE``: that network for every photo;
- ``--class wood|plastic|metal``: that shipped network for every photo; DEFAULT_CLASS
  when nothing is said.

A choice (FixedNetwork) has ``input_size`` (the photo side its network takes) and
``for_photo(photo)``, which returns the network for a (3, S, S) photo and a dict saying which
one (``model``: its file), and ``model_files``, the files its estimates depend on (what a
resumed batch compares, train.estimation.batch). The shipped material classifier that picked a
class network per photo (``--class auto``) was removed on 2026-12-04: on the real-set
validation its picks relit 1.57x worse than the naive baseline, 1.25x with route costs
measured there, and no threshold chosen on three folds helped on the fourth
(docs/experiments/2026-12-04-material-classifier-removed.md).
"""

from pathlib import Path

import numpy as np

from train.networks.model_files import load_network, shipped_model_path
from train.networks.svbrdf_net import SVBRDFNet

DEFAULT_CLASS = "plastic"
"""The network a photo gets unless told otherwise: of the shipped networks, the one that relit
real materials best on the real-set validation (models/README.md, "Real-set validation and
test": 0.98x the naive baseline). The plastic network's photo-affine albedo is the photo less a
grey offset, so it keeps the photo's colour and detail on any material."""


class FixedNetwork:
    """One network for every photo."""

    def __init__(self, net: SVBRDFNet):
        self.net = net
        self.input_size = net.config.input_size

    @property
    def model_files(self) -> list[Path]:
        return [Path(self.net.source)]

    def for_photo(self, photo: np.ndarray) -> tuple[SVBRDFNet, dict]:
        return self.net, {"model": self.net.source}


def network_choice(model: str | Path | None, material_class: str,
                   device: str = "cpu") -> FixedNetwork:
    """The choice of the command line: ``model`` (a file or run folder) if given, else the
    shipped network of ``material_class``."""
    if model is not None:
        return FixedNetwork(load_network(model, device))
    return FixedNetwork(load_network(shipped_model_path(material_class), device))
