"""The Mitsuba scene template (planar_sample.xml), installed as package data
(render.scenes, read through render.common.package_data)."""
