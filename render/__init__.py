"""Everything but training: the shared conventions and I/O (``common``), the Mitsuba 3
reference renderer (``mitsuba_reference``), the torch renderer (``torch_renderer``), material
sets (``materials``), the ``render-dataset`` generator (``dataset``) and the command lines
(``cli``). docs/architecture.md maps them; conventions: docs/conventions.md."""
