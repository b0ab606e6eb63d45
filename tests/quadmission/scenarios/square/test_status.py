"""The square's status node: what it publishes stays as it was published."""

from __future__ import annotations

from typing import Any

from quadmission.scenarios.square.pilot import SquarePilot
from quadmission.scenarios.square.status import STATUS_PERIOD_S, SquareStatusNode
from runtime import DeterministicExecutor, Node, Time, qos_profile_default


def test_each_path_keeps_its_own_stamp() -> None:
    """In one process subscribers share the published object: a Path received earlier
    must not change when the next one is published."""
    ex = DeterministicExecutor()
    pilot = SquarePilot([(0.0, 0.0, 1.0), (1.0, 0.0, 1.0)], altitude=1.0,
                        context=ex.context)
    status = SquareStatusNode(pilot, [(0.0, 0.0), (1.0, 0.0)], context=ex.context)
    listener = Node("path_listener", context=ex.context)
    received: list[Any] = []
    listener.create_subscription("nav_msgs/msg/Path", "/navigation/path", received.append,
                                 qos_profile_default)
    for node in (pilot, status, listener):
        ex.add_node(node)
    ex.spin_for(4.5 * STATUS_PERIOD_S)
    stamps = [Time.from_msg(m.header.stamp).nanoseconds for m in received]
    assert len(stamps) >= 3
    assert stamps == sorted(set(stamps)), f"paths changed after publishing: {stamps}"
