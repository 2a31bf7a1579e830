"""The training schedule: which minibatch each optimizer step takes.

Phase 1, ``labeled_epochs`` epochs of labeled minibatches only. Phase 2,
``self_augmented_epochs`` epochs in which the labeled minibatches are interleaved with
``unlabeled_per_labeled`` self-augmented ones per labeled one (the paper interleaves one of
each). The ratio may be a fraction: labeled minibatch ``b`` of an epoch is preceded by
``ceil((b + 1) r) - ceil(b r)`` self-augmented ones, so r = 2 puts two before every labeled
minibatch and r = 0.5 one before every other (the first, the third, ...). Without unlabeled
data (the baseline, r = 0), phase 2 is the same labeled minibatches alone. An epoch is one
pass over the labeled training samples in a random order drawn from (seed, epoch), in
``steps_per_epoch`` full minibatches (the last partial one is dropped).

Every step's minibatch and random choices are a function of (seed, step), so a run resumed
from a checkpoint continues exactly as if it had not stopped.
"""

import math
from dataclasses import dataclass
from fractions import Fraction
from functools import cached_property

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
    unlabeled_per_labeled: float
    """Self-augmented minibatches per labeled one in phase 2 (a fraction allowed); 0 for the
    baseline."""

    def __post_init__(self):
        if not self.unlabeled_per_labeled >= 0:
            raise ValueError("unlabeled_per_labeled must be 0 or more, "
                             f"not {self.unlabeled_per_labeled}")

    @cached_property
    def _phase_two_epoch(self):
        """(kind, labeled minibatch index) of each step of a phase-2 epoch."""
        ratio = Fraction(self.unlabeled_per_labeled).limit_denominator(1000)
        steps = []
        for batch in range(self.steps_per_epoch):
            before = math.ceil((batch + 1) * ratio) - math.ceil(batch * ratio)
            steps += [(SELF_AUGMENTED, batch)] * before + [(LABELED, batch)]
        return tuple(steps)

    @property
    def total_steps(self) -> int:
        return (self.steps_per_epoch * self.labeled_epochs
                + self.self_augmented_epochs * len(self._phase_two_epoch))

    @property
    def epochs(self) -> int:
        return self.labeled_epochs + self.self_augmented_epochs

    def step(self, index: int) -> Step:
        """The Step of optimizer step ``index`` (0-based)."""
        phase_one = self.steps_per_epoch * self.labeled_epochs
        if index < phase_one:
            return Step(index // self.steps_per_epoch, LABELED, index % self.steps_per_epoch)
        epoch, within = divmod(index - phase_one, len(self._phase_two_epoch))
        kind, batch = self._phase_two_epoch[within]
        return Step(self.labeled_epochs + epoch, kind, batch)

    def ends_epoch(self, index: int) -> bool:
        """True when step ``index`` is the last of its epoch."""
        return index + 1 == self.total_steps or self.step(index + 1).epoch != self.step(index).epoch


def labeled_batch_indices(seed: int, epoch: int, batch: int, batch_size: int,
                          count: int) -> np.ndarray:
    """Sample indices of labeled minibatch ``batch`` of ``epoch``."""
    order = np.random.default_rng([seed, epoch]).permutation(count)
    return order[batch * batch_size:(batch + 1) * batch_size]
