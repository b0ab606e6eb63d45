"""A parameter our node declares after it joined the ROS 2 graph is on its rcl node too, as
a plain rclpy program sees it; and mirroring a node twice mirrors each change once.

The same set-up as test_parameters_both_ways.py: our node on the ``ros2`` transport in a
context of its own, the foreign program plain rclpy (``AsyncParameterClient`` and a
``/parameter_events`` listener) on this test session's own domain, under a namespace of
this test process's own.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from runtime import Node, Parameter, ParameterType
from runtime.processes.executor import ClockedExecutor, ParameterMirror
from tests.runtime.processes.conftest import make_transport, needs_ros2
from tests.runtime.processes.test_parameters_both_ways import Foreign

pytestmark = needs_ros2


def _python(value: Any) -> Any:
    from rclpy.parameter import parameter_value_to_python

    return parameter_value_to_python(value)


@pytest.fixture
def graph(domain_id: int, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
          ) -> Iterator[tuple[Node, ClockedExecutor, Foreign]]:
    """Our node with one parameter, mirrored twice (a launch's child and a user's code may
    both ask), and the foreign program once it sees the node's services and events."""
    monkeypatch.setenv("ROS_HOME", str(tmp_path / "ros_home"))
    ex = ClockedExecutor(make_transport("ros2", domain_id, "late_process"),
                         use_sim_time=False, config_dir=None)
    node = Node("late", context=ex.context, namespace=f"/declared_late_{os.getpid()}")
    node.declare_parameter("gain", 0.5)
    transport = ex.process_transport
    assert isinstance(transport, ParameterMirror)
    transport.mirror_parameters(node)
    transport.mirror_parameters(node)
    foreign = Foreign(domain_id, node.get_fully_qualified_name(), ex.spin_once_realtime)
    try:
        foreign.wait_matched(node)
        yield node, ex, foreign
    finally:
        foreign.close()
        ex.process_transport.close()


def _new(foreign: Foreign, name: str) -> list[Any]:
    """The values ``name`` was announced with as a new parameter, in order."""
    return [_python(p.value) for e in foreign.events for p in e.new_parameters
            if p.name == name]


def test_a_parameter_declared_after_joining_the_graph_is_read_and_set_from_outside(
        graph: Any) -> None:
    from rclpy.parameter import Parameter as RclParameter

    node, _ex, foreign = graph
    node.declare_parameter("threshold", 3)
    node.declare_parameter("names", ("a", "b"))
    listed = foreign.call(foreign.client.list_parameters(prefixes=[], depth=0)).result.names
    assert {"gain", "threshold", "names"} <= set(listed)
    values = foreign.call(foreign.client.get_parameters(["threshold", "names"])).values
    assert [_python(v) for v in values] == [3, ["a", "b"]]
    assert foreign.spin_until(lambda: _new(foreign, "names") == [["a", "b"]])
    assert _new(foreign, "threshold") == [3]
    # its later changes go both ways, as a parameter declared before the mirror's do
    assert node.set_parameters([Parameter("threshold", ParameterType.INTEGER, 4)])[0].successful
    (value,) = foreign.call(foreign.client.get_parameters(["threshold"])).values
    assert _python(value) == 4
    (taken,) = foreign.call(foreign.client.set_parameters(
        [RclParameter("threshold", RclParameter.Type.INTEGER, 5)])).results
    assert taken.successful and node.get_parameter("threshold").value == 5


def test_a_node_mirrored_twice_announces_each_change_once(graph: Any) -> None:
    from rclpy.parameter import Parameter as RclParameter

    node, _ex, foreign = graph
    assert node.set_parameters([Parameter("gain", ParameterType.DOUBLE, 0.25)])[0].successful
    (taken,) = foreign.call(foreign.client.set_parameters(
        [RclParameter("gain", RclParameter.Type.DOUBLE, 0.75)])).results
    assert taken.successful
    node.declare_parameter("marker", 1)  # events of one publisher arrive in order
    assert foreign.spin_until(lambda: _new(foreign, "marker") == [1])
    assert foreign.changed("gain") == [0.25, 0.75]
    assert _new(foreign, "marker") == [1]
