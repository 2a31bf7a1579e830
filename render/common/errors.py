"""The one exception type for bad user input, and the checks of input paths that raise it."""

from pathlib import Path


class InputError(ValueError):
    """Bad input data. The message is one line that names the file and the problem."""

    def __init__(self, path: str | Path, problem: str):
        self.path = str(path)
        self.problem = problem
        super().__init__(f"{self.path}: {problem}")


def require_folder(path: str | Path, what: str) -> Path:
    """``path`` (a Path) if it is a folder; else an InputError naming it: ``what`` not found,
    or a file where a folder is wanted."""
    path = Path(path)
    if path.is_file():
        raise InputError(path, f"is a file, not a folder ({what} expected)")
    if not path.is_dir():
        raise InputError(path, f"{what} not found")
    return path


def require_file(path: str | Path, what: str) -> Path:
    """``path`` (a Path) if it is a non-empty file; else an InputError naming it: ``what`` not
    found, a folder where a file is wanted, or an empty file."""
    path = Path(path)
    if path.is_dir():
        raise InputError(path, f"is a folder, not a file ({what} expected)")
    if not path.is_file():
        raise InputError(path, f"{what} not found")
    if path.stat().st_size == 0:
        raise InputError(path, f"empty file (0 bytes; {what} expected)")
    return path


def require_output_folder(path: str | Path) -> Path:
    """``path`` (a Path) if it is a folder or does not exist yet; else an InputError naming it."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise InputError(path, "is a file, not a folder (an output folder is expected)")
    return path
