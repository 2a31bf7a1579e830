"""Whether an output folder may be continued: the one rule of every command that resumes.

A command that resumes (``render-dataset``, ``sa-train``, ``sa-validate``) keeps its resolved
options in ``OUT/config.json``. Re-run on the same folder, it continues only if every option
that changes the result is the same; options that do not change it (the output path, the
device, worker counts, logging and checkpoint intervals: each command lists its own) may
differ, so a folder moved elsewhere, or a run started on a CPU and continued on a GPU, resumes.
Nested options (a network's configuration) are compared field by field, named with dots
(``optimizer.learning_rate``). The run that records its options also takes the folder's lock
(render.common.folder_lock) for the rest of its process: one run at a time per folder.
"""

import hashlib
import json
from collections.abc import Collection
from pathlib import Path

from render.common.atomic_files import write_json
from render.common.errors import InputError, require_output_folder
from render.common.folder_lock import lock_folder


def _flatten(options, prefix=""):
    """{dotted name: value} of a (nested) options dict, values made JSON-like."""
    flat = {}
    for name, value in options.items():
        if isinstance(value, dict):
            flat.update(_flatten(value, f"{prefix}{name}."))
        else:
            flat[f"{prefix}{name}"] = json.loads(json.dumps(value))
    return flat


def differing_options(previous: dict, current: dict,
                      may_change: Collection[str]) -> list[str]:
    """Sorted dotted names of the options that differ between two option dicts, except those
    in ``may_change`` (top-level names)."""
    old, new = _flatten(previous), _flatten(current)
    return sorted(name for name in old.keys() | new.keys()
                  if name.split(".")[0] not in may_change and old.get(name) != new.get(name))


def file_digest(path: str | Path) -> str:
    """SHA-256 of a file's bytes, hex: how a resumed run tells an input file (a model, a probe,
    a photo) from another of the same name."""
    digest = hashlib.sha256()
    with open(path, "rb") as file:
        for block in iter(lambda: file.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def continue_folder(out: str | Path, options: dict, may_change: Collection[str], command: str,
                    write: bool = True) -> bool:
    """Check that folder ``out`` is new or holds the output of the same options (except
    ``may_change``), then (if ``write``) take its lock for ``command`` and record ``options``
    in ``out/config.json``. Returns True when the folder held earlier output to continue.
    Raises InputError naming the differing options, an unreadable config.json, or the live
    run that holds the folder."""
    path = require_output_folder(out) / "config.json"
    if write:
        lock_folder(out, command)
    existed = path.is_file()
    if existed:
        try:
            previous = json.loads(path.read_text())
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
            raise InputError(path, f"cannot read the earlier options ({error})") from None
        if not isinstance(previous, dict):
            raise InputError(path, "not an options file of this project")
        differing = differing_options(previous, options, may_change)
        if differing:
            raise InputError(path, f"this folder holds output made with other options "
                                   f"(differing: {', '.join(differing)}); use another --out")
    if write:
        write_json(path, options)
    return existed
