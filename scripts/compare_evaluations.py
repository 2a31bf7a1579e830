"""Compare two sa-evaluate runs of the same photos, photo by photo (models/README.md quotes
its figures as "paired").

    .venv/bin/python scripts/compare_evaluations.py BASE/results.json NEW/results.json \
        [--metric relit_rmse] [--draws 4000] [--seed 0]

Both results must hold the same samples (sa-evaluate with the same data, --samples and
--seed). Prints a JSON line: each run's mean ``metric`` over the naive baseline's mean (the
ratio the model card reports), the paired difference NEW - BASE over that naive mean with its
standard error over photos, the share of photos NEW does better on, and the standard deviation
and 5% / 95% quantiles of NEW's ratio when the material sets are drawn again with replacement
(material_set: the set a photo's sample name names).
"""

import json

import click
import numpy as np

from render.common.errors import InputError

NAIVE_RTOL = 1e-4
"""How far the naive baseline's error of one photo may differ between the two runs (float
rounding of the renders, as with another thread count) for them to count as the same photo."""


def per_photo(path, metric):
    """{sample name: (model error, naive error)} of an sa-evaluate results.json."""
    try:
        with open(path) as file:
            samples = json.load(file)["per_sample"]
        return {s["sample"]: (s["model"][metric], s["naive"][metric]) for s in samples}
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise InputError(path, f"not an sa-evaluate results.json with {metric!r} per sample "
                               f"({error})") from None


def material_set(sample):
    """The material set of a sample name: of a render-dataset sample, its first part
    ('wood_s1_0003__circus_arena__r00_c00' -> 'wood_s1_0003'); of a sample sa-evaluate renders
    from material folders, the name less its number ('wood_s1_0003_001' -> 'wood_s1_0003')."""
    if "__" in sample:
        return sample.split("__")[0]
    return sample.rsplit("_", 1)[0]


def compare(base, new, draws, seed):
    """The JSON report of the module docstring for two per_photo dicts."""
    names = sorted(base)
    model_base = np.array([base[n][0] for n in names])
    model_new = np.array([new[n][0] for n in names])
    naive = np.array([base[n][1] for n in names])
    scale = naive.mean()
    difference = (model_new - model_base) / scale
    rows_of_set = {}
    for row, name in enumerate(names):
        rows_of_set.setdefault(material_set(name), []).append(row)
    sets = list(rows_of_set.values())
    rng = np.random.default_rng(seed)
    ratios = []
    for _ in range(draws):
        chosen = np.concatenate([sets[i] for i in rng.integers(len(sets), size=len(sets))])
        ratios.append(model_new[chosen].mean() / naive[chosen].mean())
    return {"photos": len(names), "sets": len(sets),
            "base_ratio": model_base.mean() / scale, "new_ratio": model_new.mean() / scale,
            "paired_difference": difference.mean(),
            "standard_error": difference.std(ddof=1) / np.sqrt(len(names)),
            "new_better_share": float((model_new < model_base).mean()),
            "new_ratio_bootstrap_sd": float(np.std(ratios)),
            "new_ratio_bootstrap_5_95": [float(q) for q in np.quantile(ratios, [0.05, 0.95])]}


@click.command()
@click.argument("base", type=click.Path(exists=True, dir_okay=False))
@click.argument("new", type=click.Path(exists=True, dir_okay=False))
@click.option("--metric", default="relit_rmse", show_default=True,
              help="Per-sample error of sa-evaluate to compare.")
@click.option("--draws", default=4000, show_default=True, help="Bootstrap draws over sets.")
@click.option("--seed", default=0, show_default=True)
def main(base, new, metric, draws, seed):
    try:
        first, second = per_photo(base, metric), per_photo(new, metric)
        if set(first) != set(second):
            raise InputError(new, f"holds other samples than {base}")
        if any(not np.isclose(first[n][1], second[n][1], rtol=NAIVE_RTOL) for n in first):
            raise InputError(new, f"the naive baseline's errors differ from {base}'s: "
                                  "not the same photos and relights")
    except InputError as error:
        raise click.ClickException(str(error)) from None
    print(json.dumps(compare(first, second, draws, seed)))


if __name__ == "__main__":
    main()
