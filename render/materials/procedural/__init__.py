"""Procedural material sets by class, for ``make-materials`` (docs/make-materials.md).

``wood``, ``plastic`` and ``metal`` each offer ``sample_parameters(rng)`` (every random choice,
as a JSON-serializable dict) and ``generate(parameters, size)`` (a pure function returning a
``Surface``); ``material_set`` names, seeds and regenerates sets; ``augment`` makes more sets
from real ones.
"""
