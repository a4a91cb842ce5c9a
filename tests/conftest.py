import os

os.environ.setdefault("MPLBACKEND", "Agg")

import importlib.util

import pytest


def pytest_sessionstart(session):
    """In CI the independent engines must be present: their tests must run, not skip."""
    if os.environ.get("CI", "").lower() in ("1", "true", "yes"):
        missing = [m for m in ("pinocchio", "mujoco") if importlib.util.find_spec(m) is None]
        if missing:
            raise pytest.UsageError(
                f"CI is set but {', '.join(missing)} is missing: install exoleg[validate]")
