"""The layer rule: every import in every module points down the allowed graph.

sim/ and the companion packages (flight_control/ and above) are siblings that meet only
through topics; quadmission/ (the app) is the one place that imports both. The graph is
written here once (and drawn in the README); the test reads every module's imports,
including those inside functions and ``TYPE_CHECKING`` blocks, and names each import that
points the wrong way.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

_BASE = {"interfaces"}
_RUNTIME = _BASE | {"runtime"}
_COMPANION_BASE = _RUNTIME | {"flight_control"}
#: package -> the project packages its modules may import (itself always allowed).
ALLOWED: dict[str, set[str]] = {
    "interfaces": set(),
    "runtime": _BASE,
    "sim": _RUNTIME,
    "flight_control": _RUNTIME,
    "perception": _COMPANION_BASE,
    "navigation": _COMPANION_BASE | {"perception"},
    "fsm": _COMPANION_BASE | {"perception", "navigation"},
    "ground_station": _COMPANION_BASE | {"perception", "navigation", "fsm"},
    "quadmission": _COMPANION_BASE | {"sim", "perception", "navigation", "fsm",
                                      "ground_station"},
}
PROJECT = set(ALLOWED)


def imported_modules(source: str) -> Iterator[tuple[int, str]]:
    """(line, module) of every absolute import in ``source``."""
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            yield node.lineno, node.module


def violations(package: str, source: str, where: str) -> list[str]:
    """One line per import in ``source`` (a module of ``package``) that breaks the graph."""
    out = []
    for line, module in imported_modules(source):
        top = module.split(".")[0]
        if top in PROJECT and top != package and top not in ALLOWED[package]:
            out.append(f"{where}:{line}: {package}/ imports {module} "
                       f"({package}/ may import only {sorted(ALLOWED[package]) or 'nothing'})")
    return out


def _modules() -> Iterator[tuple[str, Path]]:
    for package in sorted(ALLOWED):
        folder = ROOT / package
        if folder.is_dir():
            for path in sorted(folder.rglob("*.py")):
                yield package, path


def test_every_import_points_down_the_layer_graph() -> None:
    found = [v for package, path in _modules()
             for v in violations(package, path.read_text(), str(path.relative_to(ROOT)))]
    assert not found, "imports against the layer graph:\n" + "\n".join(found)


def test_the_walk_sees_the_packages() -> None:
    seen = {package for package, _ in _modules()}
    assert {"interfaces", "runtime", "sim", "flight_control", "quadmission"} <= seen


@pytest.mark.parametrize(("package", "line"), [
    ("flight_control", "from sim.fcu.link import Link"),
    ("flight_control", "import sim.world"),
    ("sim", "from flight_control.frames import ned_to_enu"),
    ("runtime", "from sim import arena"),
    ("interfaces", "from runtime import Node"),
    ("navigation", "from fsm.mission import Mission"),
])
def test_a_wrong_way_import_is_named(package: str, line: str) -> None:
    source = f"def f():\n    if True:\n        {line}\n"
    (found,) = violations(package, source, "x.py")
    assert found.startswith(f"x.py:3: {package}/ imports {line.split()[1]}")


@pytest.mark.parametrize(("package", "line"), [
    ("quadmission", "from sim.fcu.sitl import build_sitl"),
    ("quadmission", "from flight_control.bridge_node import FcuBridgeNode"),
    ("sim", "from interfaces.px4.timesync import Px4Timesync"),
    ("flight_control", "from interfaces.px4 import VehicleCmd"),
    ("navigation", "from perception.aruco import detect"),
    ("sim", "import numpy"),
])
def test_an_allowed_import_passes(package: str, line: str) -> None:
    assert violations(package, line + "\n", "x.py") == []


#: Pure modules: algorithms, policies and message builders (STYLE.md 1 and 16). Each is
#: tested without the runtime, so importing it must not load one, nor MuJoCo.
PURE_MODULES = (
    "flight_control.frames", "flight_control.policy", "flight_control.pose_history",
    "flight_control.px4_messages",
    "flight_control.fcu_messages", "interfaces.px4.timesync", "perception.aruco",
    "perception.scan_policy", "navigation.astar", "navigation.voxel_graph",
    "navigation.precision_landing", "navigation.precision_land_policy",
    "navigation.navigator_policy", "fsm.mission_driver", "fsm.mission_machine",
    "navigation.navigator_messages", "perception.messages",
)


def test_pure_modules_load_no_runtime_and_no_simulator() -> None:
    """One interpreter imports them all and lists what came with them: a pure module that
    pulls in runtime/ (directly, or through a package __init__ that imports nodes) or
    MuJoCo is named."""
    script = (
        "import importlib, sys\n"
        f"for name in {PURE_MODULES!r}:\n"
        "    before = set(sys.modules)\n"
        "    importlib.import_module(name)\n"
        "    extra = sorted(m for m in set(sys.modules) - before\n"
        "                   if m.split('.')[0] in ('runtime', 'sim', 'mujoco', 'rclpy'))\n"
        "    if extra:\n"
        "        print(name, 'loads', ', '.join(extra[:5]))\n"
    )
    done = subprocess.run([sys.executable, "-c", script], cwd=ROOT, capture_output=True,
                          text=True, timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    assert done.stdout == "", done.stdout
