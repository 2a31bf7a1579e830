"""Files installed with the packages: the scene template, the bundled probes, the shipped models.

They live in the repository's own folders (``scenes/``, ``probes/``, ``models/``), which
pyproject.toml installs as the data packages ``render.scenes``, ``render.bundled_probes`` and
``train.shipped_models``: an editable install finds them in the checkout, a wheel carries them
into site-packages. Either way they are found with ``importlib.resources``, never by a path
relative to a module, so the commands work from any folder once installed.
"""

from importlib.resources import files
from pathlib import Path

from render.common.errors import InputError

SCENES = "render.scenes"
BUNDLED_PROBES = "render.bundled_probes"


def installed_file(package: str, name: str) -> Path:
    """The file ``name`` installed as data of the data package ``package`` (SCENES,
    BUNDLED_PROBES, or train's SHIPPED_MODELS); an InputError naming it when this installation
    lacks it."""
    path = Path(str(files(package) / name))
    if not path.is_file():
        raise InputError(path, "file missing from this installation")
    return path
