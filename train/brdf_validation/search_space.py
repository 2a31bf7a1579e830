"""The search space of the paper's BRDF-net validation, and its labeled subsamplings.

Homogeneous Ward BRDFs (diffuse albedo, specular albedo, roughness alpha):
- training grid: 10 diffuse x 10 specular albedos uniform in [0.05, 1], 15 roughnesses
  log-uniform in [0.02, 1] (1,500 BRDFs);
- test set: the mid-points between consecutive training values, 9 x 9 x 14 (1,134 BRDFs);
  roughness mid-points are geometric means.
Labeled subsets: ``dense`` (all), regular ``AxBxC`` patterns (A diffuse, B specular and C
roughness values, evenly spaced indices including both ends), or ``random-P`` (P percent of
the grid, seeded). The unlabeled set is the rest of the grid, or, for the labeled-unlabeled
ratio table, a disjoint random subset (``random_split``). BRDF-net predicts
``(log(diffuse / specular), log(alpha))``: only the ratio of the albedos is observable.
"""

import re

import numpy as np

DIFFUSE = np.linspace(0.05, 1.0, 10)
SPECULAR = np.linspace(0.05, 1.0, 10)
ROUGHNESS = np.geomspace(0.02, 1.0, 15)
PATTERN = re.compile(r"^(dense|(\d+)x(\d+)x(\d+)|random-(\d+(?:\.\d+)?))$")


def grid(diffuse: np.ndarray, specular: np.ndarray, roughness: np.ndarray) -> np.ndarray:
    """(N, 3) BRDFs of the product of the three value lists, roughness varying fastest."""
    d, s, r = np.meshgrid(diffuse, specular, roughness, indexing="ij")
    return np.stack([d.ravel(), s.ravel(), r.ravel()], -1)


def training_brdfs() -> np.ndarray:
    return grid(DIFFUSE, SPECULAR, ROUGHNESS)


def test_brdfs() -> np.ndarray:
    return grid((DIFFUSE[1:] + DIFFUSE[:-1]) / 2, (SPECULAR[1:] + SPECULAR[:-1]) / 2,
                np.sqrt(ROUGHNESS[1:] * ROUGHNESS[:-1]))


def labeled_mask(pattern: str, seed: int = 0) -> np.ndarray:
    """Boolean (1500,) mask of the labeled training BRDFs of ``pattern``."""
    match = PATTERN.match(pattern)
    if not match:
        raise ValueError(f"unknown sampling pattern '{pattern}' (dense, AxBxC or random-P)")
    shape = (len(DIFFUSE), len(SPECULAR), len(ROUGHNESS))
    if pattern == "dense":
        return np.ones(np.prod(shape), bool)
    if match[5] is not None:
        count = max(1, round(float(match[5]) / 100 * np.prod(shape)))
        mask = np.zeros(np.prod(shape), bool)
        mask[np.random.default_rng(seed).choice(np.prod(shape), count, replace=False)] = True
        return mask
    counts = [int(match[i]) for i in (2, 3, 4)]
    if any(not 1 <= c <= n for c, n in zip(counts, shape)):
        raise ValueError(f"pattern {pattern} does not fit the {shape} grid")
    axes = [np.round(np.linspace(0, n - 1, c)).astype(int) if c > 1 else np.array([n // 2])
            for c, n in zip(counts, shape)]
    mask = np.zeros(shape, bool)
    mask[np.ix_(*axes)] = True
    return mask.ravel()


def targets(brdfs: np.ndarray) -> np.ndarray:
    """(N, 2) BRDF-net targets: log(diffuse / specular), log(alpha)."""
    return np.stack([np.log(brdfs[:, 0] / brdfs[:, 1]), np.log(brdfs[:, 2])], -1)


def random_split(labeled_percent: float, unlabeled_percent: float,
                 seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Disjoint random labeled and unlabeled masks over the grid, of the given percentages
    (the paper's labeled-unlabeled ratio table)."""
    if labeled_percent + unlabeled_percent > 100:
        raise ValueError("labeled and unlabeled percentages add up to more than 100")
    size = len(DIFFUSE) * len(SPECULAR) * len(ROUGHNESS)
    order = np.random.default_rng(seed).permutation(size)
    labeled_count = round(labeled_percent / 100 * size)
    unlabeled_count = round(unlabeled_percent / 100 * size)
    labeled, unlabeled = np.zeros(size, bool), np.zeros(size, bool)
    labeled[order[:labeled_count]] = True
    unlabeled[order[labeled_count:labeled_count + unlabeled_count]] = True
    return labeled, unlabeled
