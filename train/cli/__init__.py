"""The training side's command lines (sa-train, sa-estimate, sa-validate): each parses its
options, builds a frozen config and calls run(cfg)."""
