"""Try: the removed material classifier's probabilities routed again, offline, on the real-set
validation (docs/experiments/2026-12-04-material-classifier-removed.md).

Input: a scripts/real_validation.py validation folder written by commit 0f8b857 or earlier
(when ``--class auto`` existed), holding ``<fold>/<choice>/results.json`` for the choices
general, wood, plastic, metal and auto: the same photos for every choice, so each photo has
every network's relit error, and the auto records hold the classifier's probabilities. Each
routing below picks a network per photo from those probabilities and takes that network's
recorded errors; nothing is estimated again. Prints relit / naive (ratio of means) for:

- least expected cost, the costs (each network's mean relit RMSE on each kind of set) measured
  on the other three folds;
- a class network only where its probability exceeds a threshold, else plastic, the threshold
  chosen on the other three folds (wood; metal; wood and metal);
- plastic for every photo, and two that are not methods: the best wood threshold on all four
  folds, and routing by the sets' true kind.

    .venv/bin/python experiments/route_classifier_offline.py VALIDATION_FOLDER
"""

import json
import sys
from pathlib import Path

import numpy as np

NETWORKS = ("wood", "plastic", "metal", "general")
METAL_SETS = {"ambientcg_Metal007", "ambientcg_Metal009", "ambientcg_Metal012",
              "ambientcg_Metal055A", "ambientcg_Chainmail004"}
"""The validation sets whose truth is a metal (a metalness map); the rest are dielectrics."""
WOOD_SETS = {"materialx_wood", "ambientcg_WoodFloor043", "godot_texture_wood"}
FOLDS = ("fold1", "fold2", "fold3", "fold4")
THRESHOLDS = (0.5, 0.6, 0.7, 0.8, 0.85, 0.9, 0.93, 0.95, 0.97, 0.98, 0.99, 0.995, 1.01)


def kind(record):
    name = record["sample"].rsplit("_", 1)[0]
    return "metal" if name in METAL_SETS else "wood" if name in WOOD_SETS else "general"


def read_photos(folder):
    """{fold: [{choice: that choice's record of the photo}]}, photos in the same order."""
    photos = {}
    for fold in FOLDS:
        by_photo = {}
        for choice in NETWORKS + ("auto",):
            results = json.loads((folder / fold / choice / "results.json").read_text())
            for record in results["per_sample"]:
                by_photo.setdefault((record["sample"], record["photo_probe"]), {})[choice] = record
        photos[fold] = list(by_photo.values())
    return photos


def ratio(photos, folds, route):
    """Relit / naive over the photos of ``folds``, each estimated by the network
    ``route(photo)`` names."""
    chosen = [photo[route(photo)] for fold in folds for photo in photos[fold]]
    return (sum(r["model"]["relit_rmse"] for r in chosen)
            / sum(r["naive"]["relit_rmse"] for r in chosen))


def costs_without(photos, left_out):
    """Costs (route x network) of the folds other than ``left_out``: rows wood, plastic, metal,
    general by the sets' kind (plastic's row: the dielectrics', as general's)."""
    rows = {}
    for fold in FOLDS:
        if fold != left_out:
            for photo in photos[fold]:
                rows.setdefault(kind(photo["plastic"]), []).append(
                    [photo[n]["model"]["relit_rmse"] for n in NETWORKS])
    mean = {name: np.mean(values, axis=0) for name, values in rows.items()}
    mean["plastic"] = mean["general"]
    return np.array([mean[name] for name in NETWORKS])


def probabilities(photo):
    return np.array([photo["auto"]["class_probabilities"][n] for n in NETWORKS])


def above(threshold, routes):
    return lambda photo: next((r for r in routes if probabilities(photo)[NETWORKS.index(r)]
                               > threshold), "plastic")


def main(folder):
    photos = read_photos(Path(folder))
    model = naive = 0.0
    for fold in FOLDS:
        costs = costs_without(photos, fold)
        chosen = [photo[NETWORKS[int(np.argmin(probabilities(photo) @ costs))]]
                  for photo in photos[fold]]
        model += sum(r["model"]["relit_rmse"] for r in chosen)
        naive += sum(r["naive"]["relit_rmse"] for r in chosen)
    print(f"least expected cost, costs of the other folds: {model / naive:.4f}")
    for routes in (("wood",), ("metal",), ("wood", "metal")):
        model = naive = 0.0
        picked = []
        for fold in FOLDS:
            others = [f for f in FOLDS if f != fold]
            best = min(THRESHOLDS, key=lambda t: ratio(photos, others, above(t, routes)))
            picked.append(best)
            chosen = [photo[above(best, routes)(photo)] for photo in photos[fold]]
            model += sum(r["model"]["relit_rmse"] for r in chosen)
            naive += sum(r["naive"]["relit_rmse"] for r in chosen)
        print(f"{' and '.join(routes)} above a threshold chosen on the other folds {picked}: "
              f"{model / naive:.4f}")
    print(f"plastic for every photo: {ratio(photos, FOLDS, lambda p: 'plastic'):.4f}")
    best = min(THRESHOLDS, key=lambda t: ratio(photos, FOLDS, above(t, ("wood",))))
    print(f"(not a method) wood above {best}, chosen on all folds: "
          f"{ratio(photos, FOLDS, above(best, ('wood',))):.4f}")
    truth = {"metal": "metal", "wood": "wood", "general": "plastic"}
    print(f"(not a method) the true kind: "
          f"{ratio(photos, FOLDS, lambda p: truth[kind(p['plastic'])]):.4f}")


if __name__ == "__main__":
    main(sys.argv[1])
