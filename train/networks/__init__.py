"""Networks and their files: SVBRDF-net's networks and parts, training checkpoints, shipped model
files."""
