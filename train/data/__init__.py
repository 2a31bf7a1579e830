"""Data for training: labeled datasets, labeled maps rendered on the fly, photos, unlabeled
images."""
