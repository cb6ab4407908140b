"""The package's layout: no import cycle between its folders; every import follows the data flow.

Every module of ``src/leakdiag`` is parsed with :mod:`ast`; every import of the package's own
modules counts, at the top of a file or inside a function (a lazy import is still a dependency).
An import ``A -> B`` between two top-level folders must go down :data:`LAYERS`; the order is
written here once and explained in ``docs/layout.md``. A failure names the offending edges with
file and line.
"""

from __future__ import annotations

import ast
from collections import defaultdict
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "leakdiag"

#: The data flow, first to last: a folder may import only folders before it. The root modules
#: ``_version``, ``_fingerprint``, ``_numba_cache``, ``_validation``, ``_holds`` and ``_format``
#: come first
#: (everybody may use them); ``leakdiag``
#: is the root package's lazy facade (``leakdiag/__init__.py``), which only the command line uses.
LAYERS = ("_version", "_fingerprint", "_numba_cache", "_validation", "_holds", "_format", "io",
          "sim",
          "features", "detect", "literature", "runtime", "studies", "report", "stream", "batch", "bench", "store", "dashboard",
          "leakdiag", "cli")

_ROOT = "leakdiag"


def _module_name(path: Path, src: Path) -> tuple[str, bool]:
    parts = list(path.relative_to(src.parent).with_suffix("").parts)
    is_pkg = parts[-1] == "__init__"
    if is_pkg:
        parts = parts[:-1]
    return ".".join(parts), is_pkg


def _unit(module: str) -> str:
    """Top-level folder (or root module) of ``leakdiag.x.y``; ``leakdiag`` for the root."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else _ROOT


def _imports(path: Path, src: Path) -> list[tuple[str, int]]:
    """Every ``leakdiag...`` module named by an import in the file, with its line."""
    name, is_pkg = _module_name(path, src)
    package = name.split(".") if is_pkg else name.split(".")[:-1]
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(node, ast.Import):
            out += [(a.name, node.lineno) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module
            # ``from leakdiag import features``: the sub-package is the dependency
            subs = [f"{target}.{a.name}" for a in node.names
                    if _is_module(f"{target}.{a.name}", src)]
            out += [(t, node.lineno) for t in subs or [target]]
    return [(t, line) for t, line in out if t == _ROOT or t.startswith(_ROOT + ".")]


def _is_module(name: str, src: Path) -> bool:
    rel = Path(*name.split(".")[1:])
    return bool(rel.parts) and ((src / rel).is_dir() or (src / rel).with_suffix(".py").is_file())


def folder_edges(src: Path = SRC) -> dict[tuple[str, str], list[str]]:
    """``(from_folder, to_folder) -> ["file:line", ...]`` for imports that cross folders.

    Parameters
    ----------
    src : pathlib.Path
        The ``leakdiag`` package folder.

    Returns
    -------
    dict
        One entry per pair of distinct units (folders, root modules, or ``leakdiag`` itself).
    """
    edges: dict[tuple[str, str], list[str]] = defaultdict(list)
    for path in sorted(src.rglob("*.py")):
        here = _unit(_module_name(path, src)[0])
        for target, line in _imports(path, src):
            there = _unit(target)
            if there != here:
                edges[(here, there)].append(f"{path.relative_to(src.parent)}:{line}")
    return dict(edges)


def find_cycle(edges) -> list[str] | None:
    """One cycle of the folder graph as ``[a, b, ..., a]``, or None.

    Parameters
    ----------
    edges : iterable of (str, str)
        Directed edges.

    Returns
    -------
    list of str or None
    """
    graph = defaultdict(set)
    for a, b in edges:
        graph[a].add(b)
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(node):
        state[node] = 1
        path.append(node)
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 1:
                return path[path.index(nxt):] + [nxt]
            if nxt not in state:
                found = visit(nxt)
                if found:
                    return found
        path.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state:
            found = visit(node)
            if found:
                return found
    return None


def _where(edges, a, b) -> str:
    return f"  {a} -> {b}: " + ", ".join(edges[(a, b)])


EDGES = folder_edges()


def test_the_scan_sees_the_package():
    # the parser finds what we know is there
    assert any(w.startswith("leakdiag/batch/runner.py:") for w in EDGES[("batch", "runtime")])
    assert ("cli", "studies") in EDGES and ("report", "studies") in EDGES
    units = {u for pair in EDGES for u in pair}
    folders = {p.name for p in SRC.iterdir() if (p / "__init__.py").is_file()}
    assert folders <= units | {"leakdiag"}


def test_every_folder_has_a_place_in_the_flow():
    folders = {p.name for p in SRC.iterdir() if (p / "__init__.py").is_file()}
    roots = {p.stem for p in SRC.glob("_*.py") if p.name != "__init__.py"}
    missing = sorted((folders | roots | {_ROOT}) - set(LAYERS))
    assert not missing, (f"folders or root modules missing from LAYERS in {__file__} (and "
                         f"docs/layout.md): {missing}")


def test_no_cycle_between_folders():
    cycle = find_cycle(EDGES)
    assert cycle is None, "import cycle between folders:\n" + "\n".join(
        _where(EDGES, a, b) for a, b in zip(cycle, cycle[1:]))


def test_imports_follow_the_data_flow():
    rank = {u: i for i, u in enumerate(LAYERS)}
    bad = [(a, b) for a, b in EDGES if rank.get(a, -1) <= rank.get(b, len(LAYERS))]
    assert not bad, ("imports against the data flow " + " -> ".join(LAYERS) + ":\n"
                     + "\n".join(_where(EDGES, a, b) for a, b in sorted(bad)))


def module_cycles(src: Path = SRC) -> list[list[str]]:
    """Groups of modules that import each other, directly or round a loop (each sorted).

    Parameters
    ----------
    src : pathlib.Path
        The ``leakdiag`` package folder.

    Returns
    -------
    list of list of str
        Strongly connected components of more than one module (a module importing its own
        parent package does not count).
    """
    graph = defaultdict(set)
    names = {_module_name(p, src)[0] for p in src.rglob("*.py")}
    for path in src.rglob("*.py"):
        here = _module_name(path, src)[0]
        for target, _ in _imports(path, src):
            if target in names and target != here and not here.startswith(target + "."):
                graph[here].add(target)
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    groups = []

    def connect(v):  # Tarjan's strongly connected components
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in graph[v]:
            if w not in index:
                connect(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while not group or group[-1] != v:
                group.append(stack.pop())
            if len(group) > 1:
                groups.append(sorted(group))

    for v in sorted(names):
        if v not in index:
            connect(v)
    return sorted(groups)


#: Module-level cycles inside a folder left for the folder's owners (issue 16); the test fails
#: when a new one appears. Delete an entry here when its cycle is gone.
KNOWN_MODULE_CYCLES = [
    ["leakdiag.sim.sensor_chain", "leakdiag.sim.sensors"],
]


def test_no_new_cycle_between_modules():
    cycles = module_cycles()
    new = [c for c in cycles if c not in KNOWN_MODULE_CYCLES]
    assert not new, f"modules that import each other (round a loop): {new}"
    gone = [c for c in KNOWN_MODULE_CYCLES if c not in cycles]
    assert not gone, f"cycles fixed: delete them from KNOWN_MODULE_CYCLES: {gone}"


def _write(root: Path, rel: str, text: str) -> None:
    f = root / "leakdiag" / rel
    f.parent.mkdir(parents=True, exist_ok=True)
    f.write_text(text)


def test_a_lazy_back_edge_is_caught_with_file_and_line(tmp_path):
    _write(tmp_path, "__init__.py", "")
    _write(tmp_path, "io/__init__.py", "")
    _write(tmp_path, "io/a.py", "def f():\n    from leakdiag.report import x\n")
    _write(tmp_path, "report/__init__.py", "from . import y\n")
    _write(tmp_path, "report/y.py", "import leakdiag.io.a\nfrom leakdiag import io, report\n")
    edges = folder_edges(tmp_path / "leakdiag")
    assert edges == {("io", "report"): ["leakdiag/io/a.py:2"],
                     ("report", "io"): ["leakdiag/report/y.py:1", "leakdiag/report/y.py:2"]}
    assert find_cycle(edges) in (["io", "report", "io"], ["report", "io", "report"])
    assert module_cycles(tmp_path / "leakdiag") == [["leakdiag.io.a", "leakdiag.report",
                                                    "leakdiag.report.y"]]


@pytest.mark.parametrize("edges,cycle", [
    ([("a", "b"), ("b", "c")], None),
    ([("a", "b"), ("b", "c"), ("c", "a")], ["a", "b", "c", "a"]),
])
def test_find_cycle(edges, cycle):
    assert find_cycle(edges) == cycle
