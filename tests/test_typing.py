"""The public API is typed and checked (mypy, configured in pyproject.toml)."""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_mypy_passes():
    if shutil.which("mypy") is None and subprocess.run(
        [sys.executable, "-c", "import mypy"], check=False).returncode != 0:
        pytest.skip("mypy not installed (pip install exoleg[dev])")
    r = subprocess.run([sys.executable, "-m", "mypy"], cwd=ROOT, capture_output=True, text=True,
                       check=False)
    assert r.returncode == 0, r.stdout + r.stderr
