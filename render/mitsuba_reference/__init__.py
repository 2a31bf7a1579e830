"""The Mitsuba 3 reference renderer: loading Mitsuba, the ``sa_ward`` BSDF plugin, the planar
sample scene and standalone scene files. Mitsuba is imported only when a renderer is made."""
