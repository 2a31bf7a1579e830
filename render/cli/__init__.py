"""The rendering side's command lines (render-dataset, make-materials, check-renderer): each
parses its options, builds a frozen config and calls run(cfg)."""
