"""One run at a time per output folder: an advisory lock that ends with its process.

A command that writes into an output folder takes ``OUT/.lock`` with ``flock`` (exclusive,
non-blocking) and holds it until its process ends. The kernel releases a ``flock`` when the
process exits in any way, a SIGKILL included, so a killed run never leaves the folder locked;
a second run started while the first is alive is refused in one line naming the folder and the
holder (the command and process id the holder wrote into the file). The file itself stays (it
is empty of meaning once unlocked): removing it while another run waits on it would let two
runs hold two different files.

Within one process the lock is re-entrant: a process that runs several commands on one folder
(a script calling ``run`` twice, also after moving the folder) takes it once; the lock file is
known by its inode, which a move keeps. Locks on network file systems follow their own
rules; the lock is meant for a local disk.
"""

import fcntl
import os
from pathlib import Path

from render.common.errors import InputError

LOCK_NAME = ".lock"
_held: dict[tuple[int, int], object] = {}
"""The locks this process holds, by the lock file's (device, inode); their open files keep
them."""


def lock_folder(folder: str | Path, command: str) -> None:
    """Take ``folder``'s lock for the rest of this process (creating the folder), or raise
    InputError naming the folder and the run that holds it."""
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        handle = open(folder / LOCK_NAME, "a+")
    except OSError as error:
        raise InputError(folder, f"cannot write ({error.strerror or error})") from None
    status = os.fstat(handle.fileno())
    key = (status.st_dev, status.st_ino)
    if key in _held:
        handle.close()  # closing another descriptor of the file keeps the held flock
        return
    try:
        fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        handle.seek(0)
        holder = handle.read().strip() or "another process"
        handle.close()
        raise InputError(folder, f"another run is writing into this folder ({holder}); wait "
                                 f"for it to end or use another --out") from None
    handle.seek(0)
    handle.truncate()
    handle.write(f"{command}, process {os.getpid()}\n")
    handle.flush()
    _held[key] = handle
