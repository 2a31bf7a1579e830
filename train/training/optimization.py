"""The paper's optimizer: Adam with Caffe's "inv" learning-rate policy (its Table 1).

Caffe's "inv" policy: ``lr(step) = base_lr * (1 + gamma * step)^(-power)``. Caffe's weight decay
adds ``weight_decay * w`` to the gradient before the Adam update, which is what torch's Adam
(not AdamW) does with ``weight_decay``. Caffe's Adam takes ``momentum`` as beta1 and its default
``momentum2`` 0.999 as beta2.
"""

from collections.abc import Iterable
from dataclasses import dataclass

import torch


@dataclass(frozen=True)
class OptimizerConfig:
    learning_rate: float = 0.002
    """Initial learning rate."""
    lr_gamma: float = 1e-4
    """Gamma of the "inv" policy."""
    lr_power: float = 1.0
    """Power of the "inv" policy."""
    weight_decay: float = 1e-4
    """L2 weight decay, added to the gradients."""
    momentum: float = 0.9
    """Adam's beta1."""
    momentum2: float = 0.999
    """Adam's beta2 (Caffe's default)."""


def inverse_decay(step: int, config: OptimizerConfig) -> float:
    """Factor of the initial learning rate at ``step`` under the "inv" policy."""
    return (1.0 + config.lr_gamma * step) ** -config.lr_power


def make_optimizer(parameters: Iterable[torch.nn.Parameter], config: OptimizerConfig
                   ) -> tuple[torch.optim.Adam, torch.optim.lr_scheduler.LambdaLR]:
    """(Adam optimizer, scheduler): call ``scheduler.step()`` after each ``optimizer.step()``."""
    optimizer = torch.optim.Adam(parameters, lr=config.learning_rate,
                                 betas=(config.momentum, config.momentum2),
                                 weight_decay=config.weight_decay)
    scheduler = torch.optim.lr_scheduler.LambdaLR(optimizer,
                                                  lambda step: inverse_decay(step, config))
    return optimizer, scheduler
