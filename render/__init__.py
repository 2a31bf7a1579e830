"""Ground-truth rendering of reduced SVBRDFs: material and probe loading, the Mitsuba 3
pipeline behind ``render-dataset``. Conventions: docs/conventions.md."""
