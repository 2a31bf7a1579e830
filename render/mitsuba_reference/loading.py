"""Loading Mitsuba 3 with the right variant, libLLVM and the project's plugins.

Mitsuba is imported only through ``load_mitsuba``, so that modules that do not render (the
trainer, the readers) never need it.
"""

import glob
import importlib
import os
import re
from types import ModuleType

DEFAULT_VARIANT = "llvm_ad_rgb"
MIN_LLVM_MAJOR = 16  # drjit 1.5 crashes in `fminimum` with libLLVM 15

_LIBLLVM_PATTERNS = ("/usr/lib/*/libLLVM-[0-9]*.so*", "/usr/lib/*/libLLVM.so.[0-9]*",
                     "/usr/lib/llvm-[0-9]*/lib/libLLVM*.so*")


def _newest_libllvm():
    """Path of the newest system libLLVM of a usable version, or None."""
    best = None
    for pattern in _LIBLLVM_PATTERNS:
        for path in glob.glob(pattern):
            match = re.search(r"(?:LLVM-|LLVM\.so\.|llvm-)(\d+)", path)
            if match and int(match.group(1)) >= MIN_LLVM_MAJOR:
                version = int(match.group(1))
                if best is None or version > best[0]:
                    best = (version, path)
    return best[1] if best else None


def load_mitsuba(variant: str = DEFAULT_VARIANT, threads: int | None = None) -> ModuleType:
    """Import Mitsuba, set ``variant``, register ``sa_ward``; returns the ``mitsuba`` module.

    ``threads`` limits Dr.Jit's CPU thread pool (used when several worker processes share the
    machine); it is raised to 2, since rendering hangs with a single-thread pool (seen with
    drjit 1.5.0).
    """
    if variant.startswith("llvm") and "DRJIT_LIBLLVM_PATH" not in os.environ:
        path = _newest_libllvm()
        if path:
            os.environ["DRJIT_LIBLLVM_PATH"] = path
    import drjit as dr
    import mitsuba as mi

    if variant not in mi.variants():
        raise ValueError(f"unknown Mitsuba variant '{variant}' (available: {mi.variants()})")
    if mi.variant() != variant:
        mi.set_variant(variant)
    if threads is not None and variant.startswith("llvm"):
        dr.set_thread_count(max(2, threads))  # with fewer than 2 threads drjit 1.5 hangs
    from render.mitsuba_reference import ward_bsdf

    importlib.reload(ward_bsdf)  # the plugin class subclasses the current variant's BSDF
    ward_bsdf.register()
    return mi
