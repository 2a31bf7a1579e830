"""What both sides (rendering and training) share: the error type, atomic files, image and
color I/O, probes, exposure, view directions and the relative labels. None of it imports
Mitsuba when imported (only reading a Radiance ``.hdr`` file loads it)."""
