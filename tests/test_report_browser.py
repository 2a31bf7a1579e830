"""sa-estimate's report.html opened in headless Chromium (scripts/check_report.js): every image
loads and has alt text, the console holds no error, and a screenshot is taken."""

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

from tests.conftest import REPO
from train.cli.sa_estimate import main as sa_estimate

CHECKER = REPO / "scripts" / "check_report.js"
CHROMIUM = Path("/usr/bin/chromium")


def check_in_chromium(page, screenshot):
    """(exit status, the checker's JSON report) of ``page`` opened in headless Chromium."""
    if not CHROMIUM.is_file() or not (REPO / "node_modules" / "playwright-core").is_dir():
        pytest.fail("Chromium or playwright-core is not installed: run `make setup`")
    result = subprocess.run(["node", str(CHECKER), str(page), str(screenshot)],
                            capture_output=True, text=True, timeout=120)
    return result.returncode, json.loads(result.stdout.strip().splitlines()[-1])


def test_report_loads_in_chromium_with_every_image_and_no_error(tmp_path):
    result = CliRunner().invoke(sa_estimate, [str(REPO / "scenes" / "photos" /
                                                  "brick-reference-01.jpg"),
                                              "--out", str(tmp_path / "est")])
    assert result.exit_code == 0, result.output
    status, report = check_in_chromium(tmp_path / "est" / "report.html", tmp_path / "shot.png")
    assert status == 0, report
    # photo, albedo, normals and the estimate relit under the three default probes
    assert report["images"] == 6 and not report["brokenImages"] and not report["missingAlt"]
    assert report["consoleErrors"] == [] and report["failedRequests"] == []
    shot = np.asarray(Image.open(tmp_path / "shot.png").convert("RGB"))
    assert shot.shape[1] == 1280 and shot.std() > 10  # a page with pictures, not a blank one


def test_checker_reports_a_missing_image(tmp_path):
    (tmp_path / "page.html").write_text(
        '<!DOCTYPE html><html lang="en"><head><title>t</title></head><body>'
        '<img src="absent.png" alt="an image that is not there"><img src="absent.png">'
        "</body></html>")
    status, report = check_in_chromium(tmp_path / "page.html", tmp_path / "shot.png")
    assert status == 1
    assert report["brokenImages"] == ["absent.png", "absent.png"]
    assert report["missingAlt"] == ["absent.png"]
