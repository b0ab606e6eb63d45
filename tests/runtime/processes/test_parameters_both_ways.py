"""Our node's parameters over ROS 2, as a plain rclpy program sees them: a change our node
makes itself reaches an outside parameter client, and every change, whichever side made
it, is one ParameterEvent on ``/parameter_events``.

Our node runs on the ``ros2`` transport in a context of its own; the foreign program is
plain rclpy (its own context, rclpy's executor, ``AsyncParameterClient``), on this test
session's own domain, under a namespace of this test process's own.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Iterator
from typing import Any

import pytest

from runtime import Node, Parameter, ParameterType
from runtime.parameters import ParameterDescriptor
from runtime.processes.executor import ClockedExecutor, ParameterMirror
from tests.runtime.processes.conftest import make_transport, needs_ros2

pytestmark = needs_ros2

_TIMEOUT_S = 10.0  # for discovery and answers only; nothing is timed


class Foreign:
    """A plain rclpy program: a parameter client of ``target`` and a listener of
    ``/parameter_events`` keeping the events about ``target``."""

    def __init__(self, domain_id: int, target: str, also_spin: Callable[[], None]) -> None:
        import rclpy
        from rcl_interfaces.msg import ParameterEvent
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.parameter_client import AsyncParameterClient
        from rclpy.qos import qos_profile_parameter_events

        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain_id)
        self.node = rclpy.create_node("param_tool", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.client = AsyncParameterClient(self.node, target)
        self.events: list[Any] = []

        def keep(event: Any) -> None:
            if event.node == target:
                self.events.append(event)

        self.listener = self.node.create_subscription(
            ParameterEvent, "/parameter_events", keep, qos_profile_parameter_events)
        self._also_spin = also_spin

    def wait_matched(self, node: Node) -> None:
        """Until the client sees ``node``'s parameter services and the listener has matched
        its rcl node's event publisher (and the listener's own node's)."""
        assert self.spin_until(self.client.services_are_ready)
        assert self.spin_until(lambda: any(
            (i.node_name, i.node_namespace) == (node.get_name(), node.get_namespace())
            for i in self.node.get_publishers_info_by_topic("/parameter_events"))
            and self.listener.get_publisher_count() >= 2)

    def spin_until(self, done: Callable[[], bool]) -> bool:
        deadline = time.monotonic() + _TIMEOUT_S
        while not done() and time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.005)
            self._also_spin()
        return done()

    def call(self, future: Any) -> Any:
        assert self.spin_until(future.done), "no answer from the node's parameter services"
        return future.result()

    def changed(self, name: str) -> list[Any]:
        """The values of ``name`` in the change events heard so far, in order."""
        return [_value(p.value) for e in self.events for p in e.changed_parameters
                if p.name == name]

    def close(self) -> None:
        import rclpy

        self.node.destroy_node()
        rclpy.shutdown(context=self.context)


def _value(value: Any) -> Any:
    from rclpy.parameter import parameter_value_to_python

    return parameter_value_to_python(value)


@pytest.fixture
def graph(domain_id: int) -> Iterator[tuple[Node, ClockedExecutor, Foreign]]:
    ex = ClockedExecutor(make_transport("ros2", domain_id, "tuned_process"),
                         use_sim_time=False, config_dir=None)
    node = Node("tuned", context=ex.context, namespace=f"/both_ways_{os.getpid()}")
    node.declare_parameter("gain", 0.5, ParameterDescriptor(range=(0.0, 1.0)))
    node.declare_parameter("enabled", True)
    node.declare_parameter("names", ("x", "y"))
    transport = ex.process_transport
    assert isinstance(transport, ParameterMirror)
    transport.mirror_parameters(node)
    foreign = Foreign(domain_id, node.get_fully_qualified_name(), ex.spin_once_realtime)
    try:
        foreign.wait_matched(node)
        yield node, ex, foreign
    finally:
        foreign.close()
        ex.process_transport.close()


def test_a_change_our_node_makes_itself_is_what_an_outside_client_reads(graph: Any) -> None:
    node, _ex, foreign = graph
    results = node.set_parameters([Parameter("gain", ParameterType.DOUBLE, 0.25),
                                   Parameter("enabled", ParameterType.BOOL, False),
                                   Parameter("names", ParameterType.STRING_ARRAY, ("z",))])
    assert all(r.successful for r in results)
    values = foreign.call(foreign.client.get_parameters(["gain", "enabled", "names"])).values
    assert [_value(v) for v in values] == [0.25, False, ["z"]]


def test_each_change_is_one_parameter_event_whichever_side_made_it(graph: Any) -> None:
    from rclpy.parameter import Parameter as RclParameter

    node, _ex, foreign = graph
    fqn = node.get_fully_qualified_name()
    assert node.set_parameters([Parameter("gain", ParameterType.DOUBLE, 0.25)])[0].successful
    assert foreign.spin_until(lambda: foreign.changed("gain") == [0.25])
    (event,) = [e for e in foreign.events if e.changed_parameters]
    assert event.node == fqn and not event.new_parameters and not event.deleted_parameters
    assert event.stamp.sec > 0  # the rcl node's clock (the host's: no /clock here)
    # from outside: refused (out of range) is no event; taken is one, not one per side
    (refused,) = foreign.call(foreign.client.set_parameters(
        [RclParameter("gain", RclParameter.Type.DOUBLE, 2.0)])).results
    assert not refused.successful
    (taken,) = foreign.call(foreign.client.set_parameters(
        [RclParameter("gain", RclParameter.Type.DOUBLE, 0.75)])).results
    assert taken.successful and node.get_parameter("gain").value == 0.75
    # a last change of ours: events of one publisher arrive in order, so any event the
    # steps above made in excess has arrived before this one
    assert node.set_parameters([Parameter("gain", ParameterType.DOUBLE, 0.5)])[0].successful
    assert foreign.spin_until(lambda: foreign.changed("gain")[-1:] == [0.5])
    assert foreign.changed("gain") == [0.25, 0.75, 0.5]
    assert {e.node for e in foreign.events} == {fqn}


def test_a_change_our_node_refuses_is_neither_shown_nor_announced(graph: Any) -> None:
    node, _ex, foreign = graph
    (refused,) = node.set_parameters([Parameter("gain", ParameterType.DOUBLE, 3.0)])
    assert not refused.successful
    assert node.set_parameters([Parameter("enabled", ParameterType.BOOL, False)])[0].successful
    assert foreign.spin_until(lambda: foreign.changed("enabled") == [False])
    assert foreign.changed("gain") == []
    (gain,) = foreign.call(foreign.client.get_parameters(["gain"])).values
    assert _value(gain) == 0.5
