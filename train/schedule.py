"""The training schedule: which minibatch each optimizer step takes.

Phase 1, ``labeled_epochs`` epochs of labeled minibatches only. Phase 2,
``self_augmented_epochs`` epochs in which each labeled minibatch is preceded by
``unlabeled_per_labeled`` self-augmented ones (the paper interleaves one of each); without
unlabeled data (the baseline), phase 2 is the same labeled minibatches alone. An epoch is one
pass over the labeled training samples in a random order drawn from (seed, epoch), in
``steps_per_epoch`` full minibatches (the last partial one is dropped).

Every step's minibatch and random choices are a function of (seed, step), so a run resumed
from a checkpoint continues exactly as if it had not stopped.
"""

from dataclasses import dataclass

import numpy as np

LABELED = "labeled"
SELF_AUGMENTED = "self-augmented"


@dataclass(frozen=True)
class Step:
    epoch: int
    kind: str
    """LABELED or SELF_AUGMENTED."""
    batch: int
    """Index of the labeled minibatch within its epoch (for both kinds)."""


@dataclass(frozen=True)
class Schedule:
    steps_per_epoch: int
    labeled_epochs: int
    self_augmented_epochs: int
    unlabeled_per_labeled: int
    """0 for the baseline."""

    @property
    def cycle(self):
        """Steps per labeled minibatch in phase 2."""
        return 1 + self.unlabeled_per_labeled

    @property
    def total_steps(self):
        return self.steps_per_epoch * (self.labeled_epochs
                                       + self.self_augmented_epochs * self.cycle)

    @property
    def epochs(self):
        return self.labeled_epochs + self.self_augmented_epochs

    def step(self, index):
        """The Step of optimizer step ``index`` (0-based)."""
        phase_one = self.steps_per_epoch * self.labeled_epochs
        if index < phase_one:
            return Step(index // self.steps_per_epoch, LABELED, index % self.steps_per_epoch)
        index -= phase_one
        per_epoch = self.steps_per_epoch * self.cycle
        within = index % per_epoch
        kind = SELF_AUGMENTED if within % self.cycle < self.unlabeled_per_labeled else LABELED
        return Step(self.labeled_epochs + index // per_epoch, kind, within // self.cycle)

    def ends_epoch(self, index):
        """True when step ``index`` is the last of its epoch."""
        return index + 1 == self.total_steps or self.step(index + 1).epoch != self.step(index).epoch


def labeled_batch_indices(seed, epoch, batch, batch_size, count):
    """Sample indices of labeled minibatch ``batch`` of ``epoch``."""
    order = np.random.default_rng([seed, epoch]).permutation(count)
    return order[batch * batch_size:(batch + 1) * batch_size]
