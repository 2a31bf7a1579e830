"""The ``render-dataset`` generator: tasks and their renderer, the local and Ray runners, the
output files and the dataset's contact sheet (docs/dataset-format.md)."""
