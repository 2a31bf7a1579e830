"""The training loop of sa-train: schedule, losses, self-augmentation, optimizer, data
parallelism."""
