"""Which SVBRDF-net estimates a photo: one given network, or a shipped one chosen per photo.

``sa-estimate`` and ``sa-evaluate`` take the same choices, so that what sa-evaluate measures is
what users get:

- ``--model FILE``: that network for every photo (FixedNetwork);
- ``--class wood|plastic|metal|general``: that shipped network for every photo; DEFAULT_CLASS
  when nothing is said;
- ``--class auto``: the shipped network the material classifier picks for each photo
  (ClassRouter; train.estimation.material_classifier).

A choice has ``input_size`` (the photo side its networks take; all the shipped networks share
it) and ``for_photo(photo)``, which returns the network for a (3, S, S) photo and a dict saying
which one and why (``model``: its file; with the router also ``class`` and
``class_probabilities``), and ``model_files``, the files its estimates depend on (what a
resumed batch compares, train.estimation.batch).
"""

from pathlib import Path

import numpy as np
import torch

from render.common.errors import InputError
from render.common.package_data import installed_file
from train.estimation.material_classifier import (
    ROUTES,
    MaterialClassifier,
    cheapest_route,
    load_classifier,
)
from train.networks.model_files import (
    SHIPPED_MODELS,
    load_network,
    shipped_model_path,
    shipped_network_config,
)
from train.networks.svbrdf_net import SVBRDFNet

CLASSIFIER_FILE = "material-classifier.safetensors"
"""The material classifier's file among the shipped models."""
AUTO = "auto"
DEFAULT_CLASS = "plastic"
"""The network a photo gets unless told otherwise: of the shipped networks and the classifier's
pick, the one that relit real materials best on the real-set validation (models/README.md,
"Real-set validation and test": 0.98x the naive baseline, where the classifier's pick was
1.57x). The plastic network's photo-affine albedo is the photo less a grey offset, so it keeps
the photo's colour and detail on any material."""


def shipped_classifier_path() -> Path:
    """The shipped material classifier's file."""
    return installed_file(SHIPPED_MODELS, CLASSIFIER_FILE)


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


class ClassRouter:
    """The shipped network the classifier picks for each photo (the least expected cost,
    train.estimation.material_classifier.cheapest_route), loaded when first needed."""

    def __init__(self, classifier: MaterialClassifier, device: str = "cpu"):
        self.classifier, self.device = classifier.to(device), device
        self.networks = {}
        self.input_size = shipped_network_config(shipped_model_path(ROUTES[0])).input_size

    def _network(self, route):
        if route not in self.networks:
            net = load_network(shipped_model_path(route), self.device)
            if net.config.input_size != self.input_size:
                raise InputError(net.source, "shipped networks differ in input size")
            self.networks[route] = net
        return self.networks[route]

    @property
    def model_files(self) -> list[Path]:
        return [Path(self.classifier.source)] + [shipped_model_path(r) for r in ROUTES]

    def for_photo(self, photo: np.ndarray) -> tuple[SVBRDFNet, dict]:
        image = torch.as_tensor(photo)[None].to(self.device)
        probabilities = self.classifier.probabilities(image)[0].cpu()
        route = ROUTES[cheapest_route(probabilities, self.classifier.costs)]
        net = self._network(route)
        return net, {"model": net.source, "class": route,
                     "class_probabilities": {name: round(float(p), 4)
                                             for name, p in zip(ROUTES, probabilities)}}


def network_choice(model: str | Path | None, material_class: str,
                   device: str = "cpu") -> FixedNetwork | ClassRouter:
    """The choice of the command line: ``model`` (a file or run folder) if given, else the
    shipped network of ``material_class``, or the classifier's pick for ``auto``."""
    if model is not None:
        return FixedNetwork(load_network(model, device))
    if material_class == AUTO:
        return ClassRouter(load_classifier(shipped_classifier_path()), device)
    return FixedNetwork(load_network(shipped_model_path(material_class), device))
