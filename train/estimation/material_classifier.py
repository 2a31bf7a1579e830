"""The material classifier: which shipped SVBRDF-net should estimate a photo.

The paper trains one SVBRDF-net per material class; so does this project (wood, plastic,
metal), plus a general network trained on every class and a few real sets. A class network
beats the general one on its class (models/README.md), so ``sa-estimate`` without a class
asks this classifier which network to use (``--class auto``).

The classifier sees a photo as the SVBRDF-nets do (train.data.photos.read_photo: linear RGB in
[0, 1], S x S) and gives the probability of each of ROUTES: "wood", "plastic", "metal" (the
class networks) or "general" (a material of none of these classes, for the general network).

A wrong network costs more than a wrong guess of the class: the metal network turns a plastic
into a mirror. So the network is not the most probable route's but the one of least expected
cost (``cheapest_route``): ``costs[i][j]``, measured on validation data
(scripts/measure_route_costs.py) and kept in the classifier file, is the mean relit error of
network j on photos of route i, and the expected cost of network j is the sum over i of
p_i costs[i][j].

The plastic-or-metal call decides most: the metal network relights a plastic ten times worse
than the baseline. A classifier file may therefore hold a second network of the same structure,
``plastic_or_metal``, trained on plastic and metal photos only, from many more sets of each
(scripts/train_material_classifier.py --plastic-or-metal): its odds of plastic against metal
split the probability the first network gives the two together, which leaves the
probabilities of wood and general as they were.

Structure: the SVBRDF-nets' analysis blocks (train.networks.svbrdf_net.Analysis) on the photo box
filtered to ``CLASSIFIER_CONFIG.input_size`` and gamma 1/2.2 encoded, then the mean and the
maximum of the last features over the image, and one linear layer to a logit per route.

A classifier file is a safetensors file (weights in float16; ``format`` = FORMAT, the network
configuration and the costs in its metadata), read without executing code, like the shipped
models (train.networks.model_files).
"""

import json
from collections.abc import Iterable, Sequence
from pathlib import Path

import torch
from torch import nn
from torch.nn import functional

from render.common.errors import InputError
from train.networks.model_files import load_weights_file, model_metadata, save_weights_file
from train.networks.svbrdf_net import Analysis, NetworkConfig

ROUTES = ("wood", "plastic", "metal", "general")
"""The classifier's answers: a shipped model name each (train.networks.model_files.SHIPPED)."""
FORMAT = "sa-svbrdf classifier 1"
CLASSIFIER_CONFIG = NetworkConfig(input_size=128, width=16, max_width=64, levels=5, hidden=0)
"""128 px in, 4 x 4 x 64 features out (about 0.1 M parameters); ``hidden`` is unused."""
PHOTO_ENCODING_GAMMA = 2.2
"""The photo is encoded with 1 / this before the network: perceptual, not linear, contrast."""


class MaterialClassifier(nn.Module):
    """Photo (B, 3, S, S), linear RGB in [0, 1], S a multiple of the configuration's input
    size -> logits (B, len(ROUTES))."""

    def __init__(self, config: NetworkConfig = CLASSIFIER_CONFIG):
        super().__init__()
        self.config = config
        self.analysis = Analysis(config)
        self.head = nn.Linear(2 * config.channels()[-1], len(ROUTES))
        self.plastic_or_metal = None
        """Optional second MaterialClassifier whose plastic-to-metal odds ``probabilities``
        uses (attach it with ``attach_plastic_or_metal``)."""

    def attach_plastic_or_metal(self, classifier: "MaterialClassifier") -> None:
        """Use ``classifier`` (a MaterialClassifier without a second network of its own) for
        the plastic-or-metal call."""
        if classifier.plastic_or_metal is not None:
            raise ValueError("the plastic-or-metal network cannot hold one of its own")
        self.plastic_or_metal = classifier

    def forward(self, photo: torch.Tensor) -> torch.Tensor:
        size = self.config.input_size
        if photo.shape[-1] % size or photo.shape[-2] != photo.shape[-1]:
            raise ValueError(f"photos of {tuple(photo.shape[-2:])} px are not squares of a "
                             f"multiple of {size} px")
        image = functional.avg_pool2d(photo, photo.shape[-1] // size)
        image = image.clamp(0.0, 1.0) ** (1.0 / PHOTO_ENCODING_GAMMA)
        _, features = self.analysis(image)  # (B, C, 4, 4)
        pooled = torch.cat([features.mean((2, 3)), features.amax((2, 3))], dim=1)
        return self.head(pooled)

    def probabilities(self, photo: torch.Tensor) -> torch.Tensor:
        """Probabilities of the routes, (B, len(ROUTES)), without gradients: the mean over the
        photo's 8 quarter turns and mirror images (each is a photo of the turned or mirrored
        sample under the probe turned or mirrored alike, as likely as the photo itself). With
        a plastic-or-metal network, the probability of plastic or metal is split in the
        proportion of its own two (also over the 8 views)."""
        probabilities = self._view_mean(photo)
        if self.plastic_or_metal is None:
            return probabilities
        return split_plastic_or_metal(probabilities,
                                      self.plastic_or_metal._view_mean(photo))

    def _view_mean(self, photo):
        with torch.no_grad():
            views = [torch.rot90(image, turns, (2, 3)) for image in (photo, photo.flip(3))
                     for turns in range(4)]
            return torch.stack([torch.softmax(self(view), dim=1) for view in views]).mean(0)


def split_plastic_or_metal(probabilities: torch.Tensor,
                           specialist: torch.Tensor) -> torch.Tensor:
    """``probabilities`` (B, len(ROUTES)) with the sum of plastic and metal redistributed in
    the ratio of ``specialist``'s (B, len(ROUTES)) plastic and metal probabilities."""
    plastic, metal = ROUTES.index("plastic"), ROUTES.index("metal")
    both = probabilities[:, plastic] + probabilities[:, metal]
    share = specialist[:, plastic] / (specialist[:, plastic] + specialist[:, metal]).clamp(
        min=1e-12)
    split = probabilities.clone()
    split[:, plastic], split[:, metal] = both * share, both * (1.0 - share)
    return split


def route_folders(pairs: Iterable[str], routes: Sequence[str] = ROUTES) -> dict[str, str]:
    """{route: folder} of ``ROUTE=FOLDER`` strings, one for every route of ``routes``."""
    folders = dict(pair.split("=", 1) for pair in pairs)
    if sorted(folders) != sorted(routes):
        raise ValueError(f"give one folder per route {list(routes)}, got {sorted(folders)}")
    return folders


def cheapest_route(probabilities: torch.Tensor | Sequence[float],
                   costs: torch.Tensor | Sequence[Sequence[float]]) -> int:
    """Index of the route whose network has the least expected cost, for probabilities
    (len(ROUTES),) and costs (len(ROUTES), len(ROUTES)): rows the photo's route, columns the
    network."""
    return int(torch.argmin(torch.as_tensor(probabilities, dtype=torch.float64)
                            @ torch.as_tensor(costs, dtype=torch.float64)))


def save_classifier(classifier: MaterialClassifier, path: str | Path, costs: list[list[float]],
                    metadata: dict) -> None:
    """Write the classifier's weights (float16; a plastic-or-metal network's under
    ``plastic_or_metal.``), its ``costs`` (len(ROUTES) x len(ROUTES) nested lists) and
    ``metadata`` (str -> JSON-able) as a safetensors file, atomically, readable by everyone.
    The keys this function writes (format, routes, costs, plastic_or_metal, network) are the
    file's own, whatever ``metadata`` (perhaps copied from another file) holds under them."""
    if torch.as_tensor(costs).shape != (len(ROUTES), len(ROUTES)):
        raise ValueError(f"costs must be {len(ROUTES)} x {len(ROUTES)}")
    save_weights_file(classifier, path, metadata | {
        "format": FORMAT, "routes": ROUTES, "costs": costs,
        "plastic_or_metal": classifier.plastic_or_metal is not None})


def load_classifier(path: str | Path) -> MaterialClassifier:
    """The classifier of a file written by save_classifier, in evaluation mode, float32, with
    its ``costs`` (a float64 tensor) and ``source`` (the file)."""
    path = Path(path)
    metadata = model_metadata(path, FORMAT, "classifier")
    try:
        routes = tuple(json.loads(metadata["routes"]))
        config = NetworkConfig(**json.loads(metadata["network"]))
        costs = torch.tensor(json.loads(metadata["costs"]), dtype=torch.float64)
        plastic_or_metal = json.loads(metadata.get("plastic_or_metal", "false"))
    except (KeyError, TypeError, ValueError, RuntimeError) as error:
        raise InputError(path, f"classifier has no valid configuration ({error})") from None
    if routes != ROUTES:
        raise InputError(path, f"classifier answers {list(routes)}, expected {list(ROUTES)}")
    if costs.shape != (len(ROUTES), len(ROUTES)) or not torch.isfinite(costs).all():
        raise InputError(path, f"classifier costs are not a finite {len(ROUTES)} x "
                               f"{len(ROUTES)} matrix")
    classifier = MaterialClassifier(config)
    if plastic_or_metal:
        classifier.attach_plastic_or_metal(MaterialClassifier(config))
    load_weights_file(classifier, path)
    classifier.costs, classifier.source = costs, str(path)
    return classifier.eval()
