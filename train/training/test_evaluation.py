"""Evaluation of SVBRDF-net on a dataset's test split, and pictures of its predictions.

Errors (means over the test samples): ``albedo_mse`` (relative diffuse albedo),
``normal_angle_deg``, ``log_specular_mse``, ``log_roughness_mse`` (natural logs), and
``relit_mse``: the exposed torch renders of the predicted and the true parameters compared
under lighting the photo was not taken under (the next probe of the bank, rotated by another
180 degrees). The example picture shows those renders beside the maps.
"""

from collections.abc import Sequence

import numpy as np
import torch

from render.common.color import linear_to_srgb
from render.torch_renderer.renderer import ProbeBank
from train.data.labeled_dataset import LabeledDataset
from train.networks.svbrdf_net import SVBRDFNet
from train.training.losses import LABELS, normal_angle_deg, relit

EXAMPLES = 4


def stack_items(items: Sequence[dict[str, np.ndarray | dict]],
                device: str | torch.device) -> dict[str, torch.Tensor]:
    """Dataset items -> a dict of (B, ...) float32 tensors of the network input and labels."""
    return {name: torch.as_tensor(np.stack([item[name] for item in items])).to(device)
            for name in ("image",) + LABELS}


def evaluate(net: SVBRDFNet, dataset: LabeledDataset, probes: ProbeBank, probe_names: list[str],
             batch_size: int, device: str | torch.device
             ) -> tuple[dict[str, float], torch.Tensor | None]:
    """(errors dict, example picture (3, H, W) in [0, 1] sRGB-encoded for display)."""
    totals, count, example = {}, 0, None
    net.eval()
    with torch.no_grad():
        for start in range(0, len(dataset), batch_size):
            items = [dataset[i] for i in range(start, min(start + batch_size, len(dataset)))]
            batch = stack_items(items, device)
            prediction = net(batch["image"])
            novel_probe = [(probe_names.index(item["provenance"]["probe"]) + 1) % len(probes)
                           if item["provenance"]["probe"] in probe_names else 0 for item in items]
            novel_rotation = torch.tensor([item["provenance"]["rotation_deg"] + 180.0
                                           for item in items])
            relit_prediction = relit(prediction, probes, novel_probe, novel_rotation)
            relit_truth = relit(batch, probes, novel_probe, novel_rotation)
            errors = {
                "albedo_mse": torch.mean((prediction["albedo"] - batch["albedo"]) ** 2),
                "normal_angle_deg": normal_angle_deg(prediction["normal"], batch["normal"]),
                "log_specular_mse": torch.mean((prediction["log_specular"]
                                                - batch["log_specular"]) ** 2),
                "log_roughness_mse": torch.mean((prediction["log_roughness"]
                                                 - batch["log_roughness"]) ** 2),
                "relit_mse": torch.mean((relit_prediction - relit_truth) ** 2),
            }
            for name, value in errors.items():
                totals[name] = totals.get(name, 0.0) + float(value) * len(items)
            count += len(items)
            if example is None:
                example = example_picture(batch, prediction, relit_prediction, relit_truth)
    net.train()
    return {name: total / count for name, total in totals.items()}, example


def example_picture(batch: dict[str, torch.Tensor], prediction: dict[str, torch.Tensor],
                    relit_prediction: torch.Tensor, relit_truth: torch.Tensor) -> torch.Tensor:
    """Rows of up to EXAMPLES samples: input | albedo predicted | albedo true | normal predicted
    | normal true (encoded (n + 1) / 2) | relit predicted | relit true, as one (3, H, W) display
    image."""
    rows = []
    for i in range(min(EXAMPLES, batch["image"].shape[0])):
        display = [linear_to_srgb(t.cpu().numpy()) for t in (
            batch["image"][i], prediction["albedo"][i], batch["albedo"][i].clamp(0, 1))]
        display += [(t.cpu().numpy() + 1) / 2 for t in (prediction["normal"][i],
                                                         batch["normal"][i])]
        display += [linear_to_srgb(t[i].cpu().numpy()) for t in (relit_prediction, relit_truth)]
        rows.append(np.concatenate(display, axis=2))
    return torch.as_tensor(np.concatenate(rows, axis=1))
