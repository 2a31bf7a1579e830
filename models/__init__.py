"""The shipped networks (models/README.md is their card), installed as package data
(train.shipped_models, read through train.networks.model_files)."""
