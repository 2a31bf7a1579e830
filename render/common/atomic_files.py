"""Writing files so that a reader (or a killed process) never sees a half-written one.

Every writer goes through ``atomic_path``: the data is written to a temporary name in the same
folder, then renamed over the final name with ``os.replace`` (atomic on POSIX file systems).
"""

import contextlib
import json
import os
import zipfile
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from render.common.errors import InputError


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it to ``path`` if the block succeeds.
    A failed write (disk full, no permission) raises InputError naming ``path``; whatever
    ``path`` held before is kept."""
    path = Path(path)
    tmp = path.with_name(f".{path.stem}.tmp{os.getpid()}{path.suffix}")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        yield tmp
        os.replace(tmp, path)
    except OSError as error:
        raise InputError(path, f"cannot write ({error.strerror or error})") from None
    finally:
        tmp.unlink(missing_ok=True)


def write_json(path: str | Path, data: dict) -> None:
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(data, indent=2, sort_keys=True) + "\n")


ZIP_EPOCH = (1980, 1, 1, 0, 0, 0)
"""The time stamp of every ``.npz`` member (the zip format's earliest date), so the same arrays
always give the same bytes; ``np.savez`` stamps the current time instead."""


def write_npz(path: str | Path, **arrays: np.ndarray) -> None:
    """Uncompressed ``.npz`` (fast to stream, readable by ``np.load``), written atomically; the
    same arrays give byte-identical files."""
    with atomic_path(path) as tmp:
        with zipfile.ZipFile(tmp, "w", zipfile.ZIP_STORED) as archive:
            for name, array in arrays.items():
                member = zipfile.ZipInfo(f"{name}.npy", date_time=ZIP_EPOCH)
                with archive.open(member, "w", force_zip64=True) as file:
                    np.lib.format.write_array(file, np.asanyarray(array), allow_pickle=False)
