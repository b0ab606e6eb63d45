"""Name resolution, remapping, and launch descriptions."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

import interfaces
from runtime import (
    DeterministicExecutor,
    InvalidNameError,
    LaunchDescription,
    LaunchError,
    Node,
    NodeSpec,
    launch,
)
from runtime.names import resolve_name


@pytest.mark.parametrize(
    ("name", "ns", "expected"),
    [
        ("chatter", "", "/chatter"),
        ("chatter", "/drone1", "/drone1/chatter"),
        ("/abs", "/drone1", "/abs"),
        ("~/private", "/drone1", "/drone1/node/private"),
    ],
)
def test_resolution(name: str, ns: str, expected: str) -> None:
    assert resolve_name(name, ns, "node") == expected


@pytest.mark.parametrize("bad", ["", "two//slashes", "1starts_with_digit", "sp ace", "trail/"])
def test_invalid_names_are_rejected_with_the_name(bad: str) -> None:
    with pytest.raises(InvalidNameError):
        resolve_name(bad, "", "node")


def test_remapping_applies_to_written_and_resolved_names() -> None:
    assert resolve_name("chatter", "", "n", {"chatter": "/talk"}) == "/talk"
    assert resolve_name("chatter", "/ns", "n", {"/ns/chatter": "/other"}) == "/other"


class Echo(Node):
    """Echoes /in to /out with a prefix parameter."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("echo", **kwargs)
        self.prefix = self.declare_parameter("prefix", "").value
        self.pub = self.create_publisher("std_msgs/msg/String", "out", 10)
        self.create_subscription("std_msgs/msg/String", "in", self.on_msg, 10)

    def on_msg(self, msg: Any) -> None:
        self.pub.publish(interfaces.new("std_msgs/msg/String", data=self.prefix + msg.data))


def test_launch_description_from_yaml_starts_remapped_nodes(tmp_path: Path) -> None:
    path = tmp_path / "launch.yaml"
    path.write_text(f"""
nodes:
  - factory: {__name__}:Echo
    name: first
    parameters: {{prefix: "a"}}
    remappings: {{in: /start, out: /middle}}
  - factory: {__name__}:Echo
    name: second
    namespace: /stage2
    parameters: {{prefix: "b"}}
    remappings: {{in: /middle}}
""")
    ex = DeterministicExecutor(config_dir=None)
    nodes = launch(LaunchDescription.from_yaml(path), ex)
    assert [n.get_fully_qualified_name() for n in nodes] == ["/first", "/stage2/second"]
    probe = Node("probe", context=ex.context)
    got: list[str] = []
    probe.create_subscription("std_msgs/msg/String", "/stage2/out", lambda m: got.append(m.data),
                              10)
    pub = probe.create_publisher("std_msgs/msg/String", "/start", 10)
    pub.publish(interfaces.new("std_msgs/msg/String", data="x"))
    ex.spin_for(0.1)
    assert got == ["bax"]


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("nodes:\n  - factory: nowhere.module:Thing\n", "cannot import nowhere.module"),
        ("nodes:\n  - factory: no_colon\n", "expected 'package.module:Class'"),
        ("nodes:\n  - factory: runtime:Nope\n", "runtime has no Nope"),
        ("nodes:\n  - name: x\n", r"nodes\[0\]: missing 'factory'"),
        ("nodes:\n  - factory: a:b\n    params: {}\n", r"nodes\[0\]: unknown key 'params'"),
        ("launch: []\n", "the top-level key 'nodes'"),
        ("simulator: {seed: 1}\nnodes: []\n", r"simulator: expected \{factory, parameters\}"),
    ],
)
def test_bad_launch_files_name_the_problem(tmp_path: Path, text: str, match: str) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(LaunchError, match=match):
        launch(LaunchDescription.from_yaml(path), DeterministicExecutor(config_dir=None))


def test_launch_file_with_simulator_and_process_groups(tmp_path: Path) -> None:
    path = tmp_path / "groups.yaml"
    path.write_text("simulator:\n  factory: a.b:sim\n  parameters: {seed: 3}\n"
                    "nodes:\n  - factory: a.b:One\n    process: grp\n"
                    "  - factory: a.b:Two\n    name: two\n")
    description = LaunchDescription.from_yaml(path)
    assert description.simulator is not None
    assert (description.simulator.factory, dict(description.simulator.parameters)) == (
        "a.b:sim", {"seed": 3})
    assert [n.process_name() for n in description.nodes] == ["grp", "two"]


def test_node_spec_accepts_a_class() -> None:
    ex = DeterministicExecutor(config_dir=None)
    (node,) = launch(LaunchDescription([NodeSpec(Echo, name="e2")]), ex)
    assert node.get_name() == "e2" and ex.get_nodes() == [node]
