"""Choosing the unlabeled photos whose average colors follow the labeled images' (the paper's
"Data Collection & Preprocessing": a crude but practical proxy for matching the distributions
of the unknown parameters).

Average colors are the per-image means of the network inputs (linear RGB in [0, 1]); they are
binned in a ``bins`` x ``bins`` x ``bins`` histogram over [0, 1]^3. The subset takes from each bin
a number of photos proportional to the labeled histogram, as many as the scarcest bin allows
(and at most ``limit``). Only bins holding both labeled and unlabeled images count: photos in
bins without labeled images are left out, and labeled bins without photos are ignored.
"""

import numpy as np


def color_bins(average_colors: np.ndarray, bins: int) -> np.ndarray:
    """Histogram bin index of each (N, 3) average color."""
    cells = np.clip((np.asarray(average_colors) * bins).astype(int), 0, bins - 1)
    return (cells[:, 0] * bins + cells[:, 1]) * bins + cells[:, 2]


def select_matching(labeled_colors: np.ndarray, unlabeled_colors: np.ndarray,
                    rng: np.random.Generator, bins: int = 4,
                    limit: int | None = None) -> np.ndarray:
    """Indices into ``unlabeled_colors`` of a subset whose color histogram follows the labeled
    one, over the bins that hold both labeled and unlabeled images. Raises ValueError when no
    bin does."""
    labeled, unlabeled = color_bins(labeled_colors, bins), color_bins(unlabeled_colors, bins)
    labeled_count = np.bincount(labeled, minlength=bins ** 3)
    available = np.bincount(unlabeled, minlength=bins ** 3)
    used = (labeled_count > 0) & (available > 0)
    if not used.any():
        raise ValueError("no unlabeled photo has an average color like any labeled image's")
    share = np.where(used, labeled_count, 0) / labeled_count[used].sum()
    total = int(np.floor(np.min(available[used] / share[used]) + 1e-9))
    if limit is not None:
        total = min(total, limit)
    chosen = []
    for bin_index in np.flatnonzero(used):
        members = np.flatnonzero(unlabeled == bin_index)
        chosen.extend(rng.choice(members, int(round(total * share[bin_index])), replace=False))
    return np.sort(np.asarray(chosen, dtype=int))
