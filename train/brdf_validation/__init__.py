"""sa-validate: the paper's validation of self-augmentation on BRDF-net."""
