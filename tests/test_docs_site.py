"""The documentation site builds from the checkout with no warning (Sphinx, warnings as
errors; its HTML under docs/_build, not committed), every public module of exoleg is in
its API reference, and every name of the public API -- what ``import exoleg`` offers:
its own functions and classes and its subpackages' ``__all__``, with their public
methods -- has numpydoc's Parameters and Returns sections (numpydoc's own validator,
rules GL08 no docstring, PR01 a parameter not documented, PR02 one documented that is
not a parameter, RT01 no Returns section)."""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import subprocess
import sys
from pathlib import Path

import pytest

import exoleg

ROOT = Path(__file__).resolve().parents[1]
BUILD = ROOT / "docs" / "_build"
RULES = {"GL08", "PR01", "PR02", "RT01"}


def public_modules() -> list[str]:
    """Every module of the package but the private ones (a name part starting with _)."""
    names = ["exoleg"]
    for m in pkgutil.walk_packages(exoleg.__path__, "exoleg."):
        if not any(p.startswith("_") for p in m.name.split(".")):
            names.append(m.name)
    return sorted(names)


def public_api() -> list[str]:
    """The public API's names, qualified where they are defined: the functions and
    classes ``import exoleg`` offers (``exoleg._LAZY`` and its own), and each
    subpackage's ``__all__`` -- the same whatever was imported before."""
    found: dict[int, str] = {}

    def add(x: object) -> None:
        if (inspect.isclass(x) or inspect.isfunction(x)) and \
                getattr(x, "__module__", "").startswith("exoleg"):
            found.setdefault(id(x), f"{x.__module__}.{x.__qualname__}")

    for name in sorted({*vars(exoleg), *exoleg._LAZY}):
        if not name.startswith("_"):
            x = getattr(exoleg, name)
            if not inspect.ismodule(x):
                add(x)
    for m in pkgutil.iter_modules(exoleg.__path__, "exoleg."):
        if m.ispkg and not m.name.split(".")[-1].startswith("_"):
            mod = importlib.import_module(m.name)
            for n in getattr(mod, "__all__", []):
                add(getattr(mod, n))
    names = list(found.values())
    for qual in list(names):
        mod, _, cls = qual.rpartition(".")
        obj = getattr(importlib.import_module(mod), cls)
        if inspect.isclass(obj):
            names += [f"{qual}.{m}" for m, f in vars(obj).items() if not m.startswith("_")
                      and (inspect.isfunction(f) or isinstance(f, classmethod | staticmethod))]
    return sorted(names)


def test_the_site_builds_without_a_warning() -> None:
    pytest.importorskip("sphinx", reason="Sphinx (exoleg[docs])")
    pytest.importorskip("myst_parser", reason="myst-parser (exoleg[docs])")
    r = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q",
                        "-b", "html", "-d", str(BUILD / "doctrees"), str(ROOT / "docs"),
                        str(BUILD / "html")], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-4000:]
    pages = BUILD / "html" / "api" / "generated"
    missing = [m for m in public_modules() if not (pages / f"{m}.html").exists()]
    assert not missing, missing
    assert len(public_modules()) > 150  # the package's modules, not an empty walk
    for guide in (ROOT / "docs" / "guides").glob("*.md"):
        assert (BUILD / "html" / "guides" / f"{guide.stem}.html").exists(), guide.name


def test_the_public_api_has_numpydoc_sections() -> None:
    validate = pytest.importorskip("numpydoc.validate", reason="numpydoc (exoleg[docs])")
    names = public_api()
    assert len(names) > 100  # exoleg.paper_leg, LegModel and its methods, ... (not empty)
    bad = {}
    for name in names:
        mod, _, attr = name.rpartition(".")
        try:
            obj = getattr(importlib.import_module(mod), attr)
        except ImportError:  # a method: its class's module, then the class
            m, _, c = mod.rpartition(".")
            obj = getattr(getattr(importlib.import_module(m), c), attr)
        # a Protocol is not made (what its methods take is checked, not its *args)
        rules = RULES - {"PR01"} if getattr(obj, "_is_protocol", False) else RULES
        errors = [f"{code} {text}" for code, text in validate.validate(name)["errors"]
                  if code in rules]
        if errors:
            bad[name] = errors
    assert not bad, "\n".join(f"{k}: {'; '.join(v)}" for k, v in bad.items())


def test_the_drawn_figures_come_from_the_code(tmp_path: Path) -> None:
    """docs/figures.py draws the architecture (from the floors the suite enforces) and
    the device's block diagram (from the shipped device files); the pages show them."""
    import matplotlib.image as mpimg

    sys.path.insert(0, str(ROOT / "docs"))
    import figures

    for path in figures.main(tmp_path):
        h, w, _ = mpimg.imread(path).shape
        assert h > 400 and w > 800, path.name
        assert (ROOT / "docs" / "img" / path.name).exists(), path.name
    assert "](img/architecture.png)" in (ROOT / "docs" / "architecture.md").read_text()
    assert "](img/device.png)" in (ROOT / "docs" / "device.md").read_text()
