"""The graph contract (interfaces/graph.py): its names are written there and nowhere else,
the docs page is what it gives now, and the node modules stay thin."""

from __future__ import annotations

import ast
import re
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest
import yaml

import interfaces
from interfaces import graph
from interfaces.px4.topics import FMU_IN, FMU_OUT, XRCE_SESSION

ROOT = Path(__file__).resolve().parents[2]
#: The contract modules: the only place a graph name is written.
CONTRACTS = {"interfaces/graph.py", "interfaces/px4/topics.py"}
#: Files (or folders, ending in "/") that may write a graph name anyway, each with its
#: reason: None exempts the whole file, a tuple only those names.
EXEMPT: dict[str, tuple[str, ...] | None] = {
    # a plain rclpy program for users: it imports only rclpy and the built messages;
    # test_the_user_example_names_only_contract_topics checks its names instead
    "examples/user_node.py": None,
    # tests may write the names they assert (most are rigs standing where a node or a
    # user's rclpy program would): a contract entry renamed by mistake then fails them, as
    # it would break a user's program, where a test reading the name from the contract
    # would follow the rename and pass. Tests that took a module's alias of a name use
    # the contract's entry (graph.X.name), as that module does.
    "tests/": None,
    # pages for people: they name topics in prose (docs/graph.md is generated from the
    # contract and checked by test_docs_graph_page_is_what_the_contract_gives_now)
    "docs/": None,
}
MAX_NODE_LINES = 300

_NAMES = {e.name for e in graph.ENTRIES.values()} | {
    t.name for t in (*FMU_IN.values(), *FMU_OUT.values(), *XRCE_SESSION.values())}
_ROOTS = sorted({n.split("/")[1] for n in _NAMES})
#: A string that is a graph name: absolute under one of the graph's first tokens, or private.
_GRAPH_NAME = re.compile(rf"(/({'|'.join(_ROOTS)})(/[A-Za-z0-9_]+)*|~/[A-Za-z0-9_/]+)")


def _first_party(pattern: str) -> list[Path]:
    listed = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard",
                             pattern], cwd=ROOT, capture_output=True, text=True, check=True)
    return [ROOT / p for p in listed.stdout.split()]


def _exemption(rel: str) -> tuple[str, ...] | None:
    """The names ``rel`` may write (None: any), by file or by folder; () when none."""
    for where, names in EXEMPT.items():
        if rel == where or (where.endswith("/") and rel.startswith(where)):
            return names
    return ()


def _docstrings(tree: ast.AST) -> set[int]:
    """The ids of the docstring constants (prose may name a topic)."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
                out.add(id(body[0].value))
    return out


def python_literals(path: Path) -> Iterator[tuple[int, str]]:
    """(line, text) of each string literal in ``path`` that is a graph name, and of each
    f-string that makes one whatever its fields hold (``f"/fcu/{x}"``,
    ``f"/launch/{process}/clock"``, ``f"~/{x}"``); docstrings are prose and left out."""
    tree = ast.parse(path.read_text(), str(path))
    prose = _docstrings(tree) | {id(part) for node in ast.walk(tree)  # f-strings' parts:
                                 if isinstance(node, ast.JoinedStr)  # judged whole below
                                 for part in node.values}
    for node in ast.walk(tree):
        if isinstance(node, ast.JoinedStr) and node.values:
            shape = "".join(str(v.value) if isinstance(v, ast.Constant) else "x"
                            for v in node.values)  # each field as one name token
            if _GRAPH_NAME.fullmatch(shape):
                yield node.lineno, ast.unparse(node)
        elif (isinstance(node, ast.Constant) and isinstance(node.value, str)
              and id(node) not in prose and _GRAPH_NAME.fullmatch(node.value)):
            yield node.lineno, node.value


def _strings(value: object) -> Iterator[str]:
    if isinstance(value, str):
        yield value
    elif isinstance(value, dict):
        for k, v in value.items():
            yield from _strings(k)
            yield from _strings(v)
    elif isinstance(value, list):
        for v in value:
            yield from _strings(v)


def yaml_literals(path: Path) -> Iterator[tuple[int, str]]:
    """(line, text) of each YAML string value in ``path`` that is a graph name, or holds
    one in a list (comments are prose and left out)."""
    lines = path.read_text().splitlines()
    for text in _strings(yaml.safe_load(path.read_text())):
        if _GRAPH_NAME.fullmatch(text):
            line = next((i for i, ln in enumerate(lines, 1)
                         if text in ln.split("#", 1)[0]), 0)
            yield line, text


def graph_literals() -> list[str]:
    """``file:line: literal`` of every graph name written outside the contract modules."""
    found = []
    for path in _first_party("*.py") + _first_party("*.yaml"):
        rel = path.relative_to(ROOT).as_posix()
        allowed = _exemption(rel)
        if rel in CONTRACTS or allowed is None:
            continue
        scan = python_literals if path.suffix == ".py" else yaml_literals
        found += [f"{rel}:{line}: {text!r}" for line, text in scan(path) if text not in allowed]
    return found


def test_no_graph_name_is_written_outside_the_contract() -> None:
    found = graph_literals()
    assert not found, ("graph names written outside interfaces/graph.py and "
                       "interfaces/px4/topics.py (use the contract's entries):\n"
                       + "\n".join(found))


@pytest.mark.parametrize(("source", "suffix"), [
    ('pub = node.create_publisher(T, "/fcu/odometry", qos)\n', ".py"),
    ('node.create_service(T, "~/enable", cb)\n', ".py"),
    ('ActionServer(node, T, f"~/{name}", cb)\n', ".py"),
    ('node.create_publisher(T, f"/fcu/{name}", qos)\n', ".py"),
    ('node.create_publisher(T, f"/launch/{process}/clock", qos)\n', ".py"),
    ('node:\n  ros__parameters:\n    watch: ["/mission/state"]\n', ".yaml"),
])
def test_the_scan_names_the_file_line_and_literal(tmp_path: Path, source: str,
                                                  suffix: str) -> None:
    path = tmp_path / f"written{suffix}"
    path.write_text('"""A module naming /fcu/odometry in prose."""\n' + source
                    if suffix == ".py" else source)
    scan = python_literals if suffix == ".py" else yaml_literals
    found = list(scan(path))
    assert len(found) == 1 and found[0][0] == (2 if suffix == ".py" else 3), found


def test_prose_and_other_paths_are_not_graph_names(tmp_path: Path) -> None:
    path = tmp_path / "prose.py"
    path.write_text('"""Reads /fcu/odometry."""\nX = "no /fcu/odometry yet"\n'
                    'Y = "/usr/bin/chromium"\nZ = "/api/state"\n'
                    'W = f"/fmu/out/{topic}: its size varies"\nV = f"/usr/{x}"\n')
    assert list(python_literals(path)) == []


def test_the_user_example_names_only_contract_topics() -> None:
    """The example keeps rclpy's plain literals (a user's program imports rclpy, not us):
    each must still be a contract topic of the type it uses."""
    tree = ast.parse((ROOT / "examples/user_node.py").read_text())
    used = {}
    for call in ast.walk(tree):
        if (isinstance(call, ast.Call) and isinstance(call.func, ast.Attribute)
                and call.func.attr in ("create_subscription", "create_publisher")):
            kind, name = call.args[0], call.args[1]
            assert isinstance(name, ast.Constant) and isinstance(kind, ast.Name)
            used[name.value] = kind.id
    assert used, "the example subscribes to nothing any more?"
    for name, kind in used.items():
        entry = graph.ENTRIES.get(name)
        assert isinstance(entry, graph.Topic), f"examples/user_node.py: {name} is no topic"
        assert entry.type.rsplit("/", 1)[-1] == kind, (name, entry.type, kind)


def test_no_node_module_is_over_300_lines() -> None:
    long = [f"{p.relative_to(ROOT)}: {n} lines"
            for p in _first_party("*_node.py") if p.relative_to(ROOT).parts[0] != "tests"
            if (n := len(p.read_text().splitlines())) > MAX_NODE_LINES]
    assert not long, (f"node modules over {MAX_NODE_LINES} lines (a node converts messages "
                      "and calls its pure module; move the logic there):\n" + "\n".join(long))


def test_docs_graph_page_is_what_the_contract_gives_now() -> None:
    page = ROOT / "docs/graph.md"
    assert page.read_text() == graph.markdown(), (
        "docs/graph.md is stale: run `quadmission interfaces --graph --markdown > "
        "docs/graph.md`")


def test_every_module_health_topic_is_named_after_its_module() -> None:
    assert {m: t.name for m, t in graph.HEALTH.items()} == {
        m: f"/{m}/health" for m in graph.HEALTH}
    assert all(t.publishers == (m,) and "mission" in t.subscribers
               for m, t in graph.HEALTH.items())


def test_an_actions_internal_names_derive_from_its_name() -> None:
    assert graph.NAVIGATE.feedback_topic == "/navigation/navigate/_action/feedback"
    assert graph.NAVIGATE.feedback_type == "quadmission_interfaces/action/Navigate_FeedbackMessage"
    with pytest.raises(ValueError, match="no part 'goal'; the parts are feedback"):
        graph.NAVIGATE.internal("goal")


def test_a_topic_whose_ends_cannot_match_is_refused() -> None:
    with pytest.raises(ValueError, match="/x/y: its subscribers cannot match its publishers: "
                                         "reader requests RELIABLE"):
        graph.Topic("/x/y", "std_msgs/msg/Empty", graph.MONITOR_QOS, graph.EVENTS_QOS, ("a",))
    with pytest.raises(ValueError, match="names in the contract are absolute"):
        graph.Service("x/y", "std_srvs/srv/SetBool", ("a",))


def test_each_entrys_interface_is_the_class_of_its_type() -> None:
    """``interface()`` is what every module used to look up by the entry's type name."""
    for entry in graph.ENTRIES.values():
        found = entry.interface()
        if isinstance(entry, graph.Topic):
            assert interfaces.type_name(found) == entry.type, entry.name
        else:
            assert found.name == entry.type, entry.name
    navigate = graph.NAVIGATE.interface()
    assert interfaces.type_name(navigate.Result) == "quadmission_interfaces/action/Navigate_Result"
    assert interfaces.type_name(graph.POSE_AT.interface().Request) == (
        "quadmission_interfaces/srv/PoseAt_Request")
