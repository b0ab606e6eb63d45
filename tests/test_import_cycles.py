"""No module import cycle anywhere in the house.

The walk reads every first-party module (the packages pyproject.toml ships, and the script
folders tools/, benchmarks/ and examples/, whose scripts import their siblings by bare
name) and takes the imports a module makes when it is imported: its module body's,
including those under ``if TYPE_CHECKING:``, leaving out those inside functions (made
when called, not when imported). ``TYPE_CHECKING`` imports count because a cycle through
one is still a cycle in the design: mypy and a reader follow it, and the two modules can
no longer be read, tested or moved apart; it only hides from the interpreter's import
order. An import is an arrow to the module it names: ``from a.b import c`` to ``a.b.c``
when that is a module, else to ``a.b``; a package's ``__init__`` is not counted as
imported by its submodules' imports (Python has it loaded first, without a cycle). A
cycle is named with the file and line of each arrow.
"""

from __future__ import annotations

import ast
import tomllib
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: folders of scripts (no ``__init__``): run with their own folder on ``sys.path``
SCRIPT_FOLDERS = ("tools", "benchmarks", "examples")


def shipped_packages(root: Path) -> tuple[str, ...]:
    """The top-level packages pyproject.toml ships (``[tool.setuptools.packages.find]``)."""
    pyproject = tomllib.loads((root / "pyproject.toml").read_text())
    include = pyproject["tool"]["setuptools"]["packages"]["find"]["include"]
    return tuple(sorted(pattern.rstrip("*") for pattern in include))


@dataclass(frozen=True)
class Arrow:
    """``source`` imports ``target`` at ``where`` (``path:line``)."""

    source: str
    target: str
    where: str


def _modules(root: Path, packages: tuple[str, ...], scripts: tuple[str, ...]
             ) -> dict[str, Path]:
    """Module name -> file, for every ``.py`` under the packages and script folders."""
    found: dict[str, Path] = {}
    for top in (*packages, *scripts):
        for path in sorted((root / top).rglob("*.py")):
            parts = path.relative_to(root).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
            found[".".join(parts)] = path
    return found


def _import_time_statements(body: list[ast.stmt]) -> Iterator[ast.Import | ast.ImportFrom]:
    """The import statements run when the module is imported: at module level and inside
    its ``if``/``try``/``with``/loops/class bodies, not inside functions."""
    for stmt in body:
        if isinstance(stmt, ast.Import | ast.ImportFrom):
            yield stmt
        elif not isinstance(stmt, ast.FunctionDef | ast.AsyncFunctionDef):
            for field in ("body", "orelse", "finalbody", "handlers"):
                inner = getattr(stmt, field, None)
                if isinstance(inner, list):
                    yield from _import_time_statements(
                        [s for item in inner
                         for s in (item.body if isinstance(item, ast.ExceptHandler) else [item])])


def _known(name: str, modules: dict[str, Path]) -> str | None:
    """The longest prefix of ``name`` that is a first-party module, if any."""
    parts = name.split(".")
    for end in range(len(parts), 0, -1):
        candidate = ".".join(parts[:end])
        if candidate in modules:
            return candidate
    return None


def import_arrows(root: Path, packages: tuple[str, ...],
                  scripts: tuple[str, ...] = ()) -> tuple[set[str], list[Arrow]]:
    """Every first-party module under ``root`` and the import arrows between them."""
    modules = _modules(root, packages, scripts)
    arrows: list[Arrow] = []
    for name, path in modules.items():
        is_package = path.name == "__init__.py"
        package = name if is_package else name.rpartition(".")[0]
        in_script_folder = name.split(".")[0] in scripts
        tree = ast.parse(path.read_text(), str(path))
        for stmt in _import_time_statements(tree.body):
            if isinstance(stmt, ast.Import):
                named = [alias.name for alias in stmt.names]
            else:
                base = stmt.module or ""
                if stmt.level:
                    anchor = package.split(".")[: len(package.split(".")) - stmt.level + 1]
                    base = ".".join([*anchor, *([base] if base else [])])
                named = [f"{base}.{alias.name}" if base else alias.name for alias in stmt.names]
            for full in named:
                if in_script_folder and full.split(".")[0] not in modules:
                    full = f"{package}.{full}"  # a sibling script, imported by bare name
                target = _known(full, modules)
                if target is not None and target != name:
                    where = f"{path.relative_to(root)}:{stmt.lineno}"
                    arrows.append(Arrow(name, target, where))
    return set(modules), arrows


def cycles(arrows: list[Arrow]) -> list[list[Arrow]]:
    """One cycle per strongly connected group of modules (Tarjan), as the arrows that
    close it: the shortest way from the group's first module back to itself."""
    graph: dict[str, dict[str, Arrow]] = {}
    for arrow in arrows:
        graph.setdefault(arrow.source, {}).setdefault(arrow.target, arrow)
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    groups: list[set[str]] = []

    def connect(v: str) -> None:  # recursive Tarjan: module graphs are shallow
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, {})):
            if w not in index:
                connect(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = set()
            while True:
                w = stack.pop()
                on_stack.discard(w)
                group.add(w)
                if w == v:
                    break
            if len(group) > 1:
                groups.append(group)

    for v in sorted(graph):
        if v not in index:
            connect(v)
    found = []
    for group in sorted(groups, key=min):
        start = min(group)
        paths: dict[str, list[Arrow]] = {start: []}
        frontier = [start]
        loop: list[Arrow] | None = None
        while frontier and loop is None:
            nxt = []
            for v in frontier:
                for w, arrow in sorted(graph.get(v, {}).items()):
                    if w == start:
                        loop = [*paths[v], arrow]
                        break
                    if w in group and w not in paths:
                        paths[w] = [*paths[v], arrow]
                        nxt.append(w)
                if loop is not None:
                    break
            frontier = nxt
        assert loop is not None
        found.append(loop)
    return found


def describe(loop: list[Arrow]) -> str:
    names = " -> ".join([loop[0].source, *(a.target for a in loop)])
    return names + "\n" + "\n".join(f"    {a.where}: {a.source} imports {a.target}"
                                    for a in loop)


def test_no_module_import_cycle_in_the_house() -> None:
    _modules_seen, arrows = import_arrows(ROOT, shipped_packages(ROOT), SCRIPT_FOLDERS)
    found = cycles(arrows)
    assert not found, (f"{len(found)} import cycle(s):\n"
                       + "\n".join(describe(loop) for loop in found))


def test_the_walk_sees_every_package_and_the_runtime_split() -> None:
    packages = shipped_packages(ROOT)
    assert {"interfaces", "runtime", "sim", "flight_control", "perception", "navigation",
            "fsm", "ground_station", "quadmission"} <= set(packages)
    modules, arrows = import_arrows(ROOT, packages, SCRIPT_FOLDERS)
    assert {"runtime.node", "runtime.context", "benchmarks.bench_sitl"} <= modules
    pairs = {(a.source, a.target) for a in arrows}
    assert ("runtime.node", "runtime.context") in pairs
    assert ("runtime.executor", "runtime.node") in pairs
    assert ("benchmarks.bench_sitl", "benchmarks.bench_sim") in pairs  # a bare sibling


def _tree(tmp_path: Path, files: dict[str, str]) -> Path:
    for name, text in files.items():
        path = tmp_path / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return tmp_path


@pytest.mark.parametrize(("import_line", "line"), [
    ("from pkg.a import thing", 1),
    ("import pkg.a", 1),
    ("from pkg import a", 1),
    ("from . import a", 1),
    ("from .a import thing", 1),
    ("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from pkg.a import thing", 3),
    ("try:\n    from pkg.a import thing\nexcept ImportError:\n    pass", 2),
    ("class C:\n    from pkg.a import thing", 2),
])
def test_a_cycle_is_named_with_its_arrows(tmp_path: Path, import_line: str, line: int
                                          ) -> None:
    root = _tree(tmp_path, {"pkg/__init__.py": "", "pkg/a.py": "from pkg.b import x\n",
                            "pkg/b.py": f"{import_line}\n"})
    _, arrows = import_arrows(root, ("pkg",))
    (loop,) = cycles(arrows)
    assert describe(loop).startswith("pkg.a -> pkg.b -> pkg.a\n    pkg/a.py:1: ")
    assert f"pkg/b.py:{line}: pkg.b imports pkg.a" in describe(loop)


@pytest.mark.parametrize("import_line", [
    "def f():\n    from pkg.a import thing",  # made when called, not when imported
    "from pkg import c",  # a sibling, not a
    "import pkg",  # the package's __init__, which does not import a
    "from pkgx import a",  # another package's a
])
def test_no_cycle_without_an_arrow_back(tmp_path: Path, import_line: str) -> None:
    root = _tree(tmp_path, {"pkg/__init__.py": "", "pkg/a.py": "from pkg.b import x\n",
                            "pkg/b.py": f"{import_line}\n", "pkg/c.py": "",
                            "pkgx/__init__.py": "", "pkgx/a.py": ""})
    _, arrows = import_arrows(root, ("pkg", "pkgx"))
    assert cycles(arrows) == []


def test_a_package_init_importing_its_submodule_is_no_cycle_but_importing_back_is(
        tmp_path: Path) -> None:
    files = {"pkg/__init__.py": "from pkg.a import thing\n", "pkg/a.py": "import pkg.b\n",
             "pkg/b.py": ""}
    assert cycles(import_arrows(_tree(tmp_path, files), ("pkg",))[1]) == []
    (tmp_path / "pkg/b.py").write_text("from pkg import thing\n")  # the __init__'s name
    (loop,) = cycles(import_arrows(tmp_path, ("pkg",))[1])
    assert [a.target for a in loop] == ["pkg.a", "pkg.b", "pkg"]
