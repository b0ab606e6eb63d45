"""``node_stop`` with a duration, in process: the node stops as if its process died, and
that much later a fresh instance of it starts (its process restarted): the same class,
name and parameters, none of the dead one's state, and its health reports resume. Same
seed, same run: the restart is at a simulated time, so the trace repeats."""

from __future__ import annotations

from typing import Any

import pytest

from interfaces import graph
from navigation.mapping_node import MappingNode
from quadmission.assembly.faults import AppFaults
from runtime import DeterministicExecutor, Node
from sim.fault_spec import KINDS, Duration, FaultKind, parse_fault


class _Watch(Node):
    """Hears mapping's health; plays the app's faults as the simulator's world part does."""

    def __init__(self, app: AppFaults, **kwargs: Any) -> None:
        super().__init__("watch", **kwargs)
        self.heard: list[float] = []
        health = graph.HEALTH["mapping"]
        self.create_subscription(health.type, health.name,
                                 lambda _: self.heard.append(self.now().nanoseconds / 1e9),
                                 health.subscriber_qos)
        self.create_timer(0.01, lambda: app.update(self.now().nanoseconds, None))  # type: ignore[arg-type]


def _run(spec: str, seconds: float) -> tuple[DeterministicExecutor, AppFaults, _Watch, Node]:
    ex = DeterministicExecutor(record_trace=True)
    first = MappingNode(context=ex.context, parameter_overrides={"voxel_size": 0.2})
    ex.add_node(first)
    app = AppFaults(ex, [parse_fault(spec)])
    watch = _Watch(app, context=ex.context)
    ex.add_node(watch)
    first.map.add([[1.0, 2.0, 1.0]])  # state of its own: what a restart must not carry
    ex.spin_for(seconds)
    return ex, app, watch, first


def test_node_stop_takes_an_optional_duration() -> None:
    assert KINDS[FaultKind.NODE_STOP].duration is Duration.OPTIONAL
    fault = parse_fault("node_stop@30:5,name=navigator")
    assert (fault.at_s, fault.duration_s, fault.end_s) == (30.0, 5.0, 35.0)
    assert fault.spec() == "node_stop@30:5,name=navigator"
    assert parse_fault("node_stop@30,name=navigator").duration_s is None  # for good


def test_a_stopped_node_is_made_anew_after_the_duration_and_reports_again() -> None:
    ex, app, watch, first = _run("node_stop@2.5:2,name=mapping", 7.0)
    fresh = next(n for n in ex.get_nodes() if n.get_name() == "mapping")
    assert isinstance(fresh, MappingNode) and fresh is not first
    assert first not in ex.context.nodes and first not in ex.get_nodes()
    assert ex.stopped_nodes == frozenset()
    assert app.restarted == [(4.5, "mapping")]
    assert fresh.params.voxel_size == 0.2  # its launch parameters, again
    assert len(fresh.map) == 0  # nothing of the dead one's state
    silent = [t for t in watch.heard if 2.5 < t <= 4.5]  # (mapping: 1 Hz)
    assert silent == [], f"health while stopped at {silent}"
    assert any(t < 2.5 for t in watch.heard)
    assert any(t > 4.5 for t in watch.heard), "no health report after the restart"
    # the dead instance ran nothing after its stop, not even once the name was back
    assert not [e for e in ex.trace or [] if e.node == "mapping" and 2.5 < e.t_ns / 1e9 <= 4.5]


def test_without_a_duration_the_node_stays_stopped() -> None:
    ex, app, watch, _ = _run("node_stop@2.5,name=mapping", 7.0)
    assert ex.stopped_nodes == {"mapping"} and app.restarted == []
    assert not [t for t in watch.heard if t > 2.5]


def test_a_restart_repeats_run_for_run() -> None:
    one, *_ = _run("node_stop@2.5:2,name=mapping", 7.0)
    two, *_ = _run("node_stop@2.5:2,name=mapping", 7.0)
    assert one.trace == two.trace


def test_only_a_stopped_node_can_be_restarted() -> None:
    ex = DeterministicExecutor()
    ex.add_node(MappingNode(context=ex.context))
    with pytest.raises(ValueError, match="node 'mapping' is not stopped"):
        ex.restart_node("mapping")
