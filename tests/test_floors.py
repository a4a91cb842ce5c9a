"""The house's floors (docs/architecture.md): each package of ``src/exoleg`` imports only
from its own floor's or lower floors' packages, at any level (a module's top, inside a
function, under TYPE_CHECKING alike: an import anywhere is a dependency), and no file
imports itself round a circle.

Reference: the floors declared in docs/architecture.md, after ../shared/design/
architecture.md (the second review, December 2026). The two siblings on one floor -- the
controllers and the simulated world -- never import each other.
"""

from __future__ import annotations

import ast
import functools
import sys
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1] / "src" / "exoleg"

#: Bottom to top; a package may import its own floor's and the floors below.
FLOORS = (
    ("ground", ("errors", "io", "entry", "layout", "checks", "session_log", "_cache",
                "_parent")),
    ("data", ("params", "reference", "kinematics", "inertia")),
    ("model", ("dynamics", "export")),
    ("contract", ("tick",)),
    ("parts", ("device",)),
    ("body", ("sizing",)),
    ("actors", ("child", "hw")),
    ("control | world", ("control", "world")),
    ("assembly", ("system",)),
    ("runs", ("sim",)),
    ("runtime", ("runtime",)),
    ("analyses", ("validate", "identify", "study", "design")),
    ("faces", ("cli", "hmi", "plots", "compile")),
)
LEVEL = {pkg: i for i, (_, pkgs) in enumerate(FLOORS) for pkg in pkgs}
#: Floor-mates that never import each other.
APART = frozenset({("control", "world"), ("world", "control")})


def _modules(root: Path = ROOT) -> dict[str, Path]:
    mods = {}
    for p in root.rglob("*.py"):
        parts = list(p.relative_to(root).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        mods[".".join(["exoleg", *parts])] = p
    return mods


def _imports(mods: dict[str, Path]) -> dict[str, dict[str, int]]:
    """module -> {module it imports: line}, every import statement of the file."""
    def owner(name: str) -> str:
        while name and name not in mods:
            name = name.rpartition(".")[0]
        return name

    out: dict[str, dict[str, int]] = defaultdict(dict)
    for m, p in mods.items():
        pkg = m if p.name == "__init__.py" else m.rpartition(".")[0]
        for n in ast.walk(ast.parse(p.read_text(), str(p))):
            names: list[str] = []
            if isinstance(n, ast.ImportFrom):
                if n.level:
                    up = pkg.split(".")[: len(pkg.split(".")) - (n.level - 1)]
                    base = ".".join([*up, *([n.module] if n.module else [])])
                else:
                    base = n.module or ""
                if base.split(".")[0] == "exoleg":
                    names = [f"{base}.{a.name}" if f"{base}.{a.name}" in mods else base
                             for a in n.names]
            elif isinstance(n, ast.Import):
                names = [a.name for a in n.names if a.name.split(".")[0] == "exoleg"]
            for name in names:
                target = owner(name)
                if target not in ("", "exoleg", m):
                    out[m].setdefault(target, n.lineno)
    return out


@functools.cache
def _graph() -> tuple[dict[str, Path], dict[str, dict[str, int]]]:
    """The package's modules and their imports, parsed once by the worker that runs these
    tests (not at collection, where every worker parsed the whole package)."""
    mods = _modules()
    return mods, _imports(mods)


def _package(module: str) -> str:
    return module.split(".")[1]


def test_every_package_has_a_floor() -> None:
    unplaced = sorted({_package(m) for m in _graph()[0] if m != "exoleg"} - set(LEVEL))
    assert not unplaced, f"packages on no floor (add them to FLOORS and the docs): {unplaced}"


def test_no_package_imports_a_floor_above_it_or_its_sibling() -> None:
    up = []
    mods, imports = _graph()
    for m, targets in imports.items():
        a = _package(m) if m != "exoleg" else None
        if a is None or a not in LEVEL:
            continue
        for t, line in targets.items():
            b = _package(t)
            if b != a and b in LEVEL and (LEVEL[b] > LEVEL[a] or (a, b) in APART):
                up.append(f"{mods[m].relative_to(ROOT)}:{line} ({FLOORS[LEVEL[a]][0]}) "
                          f"imports {t} ({FLOORS[LEVEL[b]][0]})")
    assert not up, "imports of a floor above:\n" + "\n".join(sorted(up))


def _circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one node (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    found: list[list[str]] = []
    sys.setrecursionlimit(max(10_000, sys.getrecursionlimit()))

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                found.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_no_package_reaches_itself() -> None:
    graph: dict[str, set[str]] = defaultdict(set)
    for m, targets in _graph()[1].items():
        for t in targets:
            if m != "exoleg" and _package(t) != _package(m):
                graph[_package(m)].add(_package(t))
    assert _circles(graph) == []


def test_no_file_circle() -> None:
    graph = {m: set(t) for m, t in _graph()[1].items()}
    assert _circles(graph) == []


def test_the_check_sees_an_upward_import(tmp_path: Path) -> None:
    """The rule's own test: a function-level import of a face from the ground is found."""
    (tmp_path / "exoleg" / "errors").mkdir(parents=True)
    (tmp_path / "exoleg" / "cli").mkdir()
    (tmp_path / "exoleg" / "errors" / "__init__.py").write_text(
        "def f():\n    from exoleg.cli.main import g\n")
    (tmp_path / "exoleg" / "cli" / "main.py").write_text("from exoleg.errors import f\n")
    (tmp_path / "exoleg" / "cli" / "__init__.py").write_text("")
    imports = _imports(_modules(tmp_path / "exoleg"))
    assert imports["exoleg.errors"] == {"exoleg.cli.main": 2}
    graph = {m: set(t) for m, t in imports.items()}
    assert _circles(graph) == [["exoleg.cli.main", "exoleg.errors"]]


def test_no_compiled_function_takes_more_than_eight_arguments() -> None:
    # issue 37: ticks of a few arguments (mj_step(model, data)'s shape) -- records and
    # tuples of them, not 14-29 positional arguments (nested records compile, cache and
    # cost less per call). Every function compiled by numba in src/exoleg, generated
    # kernels included
    wide = []
    for path in ROOT.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.FunctionDef) and any(
                    (isinstance(d, ast.Call) and getattr(d.func, "id", "") == "njit")
                    or getattr(d, "id", "") == "njit" for d in node.decorator_list):
                if len(node.args.args) > 8:
                    wide.append(f"{path.relative_to(ROOT)}:{node.name} "
                                f"({len(node.args.args)} arguments)")
    assert not wide, wide
