"""The project installed as a user installs it: from a wheel, not only editable.

The wheel must carry every package, the shipped models, the bundled probes and the scene
template inside the project's own packages, and ``sa-estimate`` must run from a folder outside
the checkout. The wheel is built without build isolation and installed into a fresh virtual
environment that sees the test environment's packages (a ``.pth`` file), so nothing is
downloaded.
"""

import json
import shutil
import subprocess
import sys
import tomllib
import venv
import zipfile

import pytest

from tests.conftest import REPO

DATA_PACKAGES = {"render.scenes": "scenes", "render.bundled_probes": "probes",
                 "train.shipped_models": "models"}


def test_pyproject_lists_every_package_and_maps_the_data_folders():
    setuptools = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]
    folders = {".".join(path.parent.relative_to(REPO).parts)
               for top in ("render", "train") for path in (REPO / top).rglob("__init__.py")}
    assert set(setuptools["packages"]) == folders | set(DATA_PACKAGES)
    assert setuptools["package-dir"] == DATA_PACKAGES


@pytest.fixture(scope="module")
def wheel(tmp_path_factory):
    """The wheel, built from a copy of the checkout without its ignored outputs (a stale
    build/ folder would leak into it)."""
    source, out = tmp_path_factory.mktemp("source") / "sa-svbrdf", tmp_path_factory.mktemp("wheel")
    shutil.copytree(REPO, source, ignore=shutil.ignore_patterns(
        ".git", ".venv", "build", "node_modules", "demo-output", "*.egg-info", "__pycache__"))
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps",
                    "--no-build-isolation", "--wheel-dir", str(out), str(source)],
                   check=True, cwd=out)
    wheels = list(out.glob("sa_svbrdf-*.whl"))
    assert len(wheels) == 1
    return wheels[0]


def test_the_wheel_holds_the_data_inside_the_project_packages(wheel):
    names = zipfile.ZipFile(wheel).namelist()
    assert all(name.split("/")[0] in ("render", "train") or ".dist-info/" in name
               for name in names), sorted({name.split("/")[0] for name in names})
    for name in ("svbrdf-wood.safetensors", "svbrdf-plastic.safetensors",
                 "svbrdf-metal.safetensors"):
        assert f"train/shipped_models/{name}" in names
    for name in ("park.exr", "env-studio.exr", "potsdamer_platz.exr"):
        assert f"render/bundled_probes/{name}" in names
    assert "render/scenes/planar_sample.xml" in names
    assert "train/estimation/estimator.py" in names


def test_sa_estimate_runs_from_the_installed_wheel_outside_the_checkout(wheel, tmp_path):
    environment = tmp_path / "venv"
    venv.EnvBuilder(with_pip=False).create(environment)
    python = environment / "bin" / "python"
    site = subprocess.run([str(python), "-c", "import site; print(site.getsitepackages()[0])"],
                          check=True, capture_output=True, text=True).stdout.strip()
    test_site = subprocess.run([sys.executable, "-c",
                                "import site; print(site.getsitepackages()[0])"],
                               check=True, capture_output=True, text=True).stdout.strip()
    # the test environment's packages, behind the new environment's own (its editable
    # install of this project is not active there: .pth files of an added folder are not read)
    (environment / site / "zz-test-environment.pth").write_text(test_site + "\n")
    subprocess.run([sys.executable, "-m", "pip", "--python", str(python), "install", "--quiet",
                    "--no-deps", "--no-index", str(wheel)], check=True)
    work = tmp_path / "elsewhere"
    work.mkdir()
    photo = REPO / "scenes" / "photos" / "brick-reference-01.jpg"
    result = subprocess.run([str(environment / "bin" / "sa-estimate"), str(photo), "--out",
                             "estimate", "--max-side", "128"],
                            cwd=work, capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout.splitlines()[0])
    assert report["model"].startswith(str(environment)), report["model"]
    folder = work / "estimate" / "brick-reference-01"
    for name in ("albedo.exr", "normal.png", "material.json", "scene.xml", "material.glb",
                 "relit-park.png", "preview.png"):
        assert (folder / name).is_file(), name
    assert (work / "estimate" / "report.html").is_file()
