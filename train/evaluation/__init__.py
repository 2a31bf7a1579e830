"""sa-evaluate: a model's estimates on labeled test data against the naive baseline."""
