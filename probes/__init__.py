"""The bundled HDR probes (probes/CREDITS.md), installed as package data
(render.bundled_probes, read through render.common.package_data)."""
