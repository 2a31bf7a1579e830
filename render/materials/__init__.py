"""Material sets: reading material folders into the reduced SVBRDF (and writing them), map
file names, the procedural classes, ``make-materials`` and its contact sheet."""
