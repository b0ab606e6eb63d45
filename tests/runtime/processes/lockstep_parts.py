"""Parts of the lockstep test's launch: a bare simulated world and a slow node.

:func:`world` is a launch simulator with nothing in it but time: it steps its executor at
the tick rate, and notes how far ahead of :class:`SlowNode` it is each time that node
says where it is. ``SlowNode`` burns 20 ms of host time every 10 ms of simulated time,
so it can follow only at half real time while the world could run as fast as it likes.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import interfaces
from runtime import DeterministicExecutor, Node, qos_profile_default
from runtime.clock import Time
from runtime.launch import SimulationResult

CLOCK_TYPE = "rosgraph_msgs/msg/Clock"
WHERE = "/lockstep_test/slow_node_time"
SLOW_PERIOD_S = 0.01  # simulated
SLOW_BUSY_S = 0.02  # host time burnt per period


class SlowNode(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("slow_node", **kwargs)
        self.pub = self.create_publisher(CLOCK_TYPE, WHERE, qos_profile_default)
        self.create_timer(SLOW_PERIOD_S, self.work)

    def work(self) -> None:
        self.pub.publish(interfaces.new(CLOCK_TYPE, clock=self.now().to_msg()))
        end = time.perf_counter() + SLOW_BUSY_S
        while time.perf_counter() < end:
            pass


class BareWorld:
    """Time and nothing else; ``run`` reports the largest lead over the slow node seen."""

    def __init__(self, executor: DeterministicExecutor) -> None:
        self.executor = executor
        self.node = Node("bare_world", context=executor.context)
        executor.add_node(self.node)
        self.leads_ns: list[int] = []
        self.node.create_subscription(CLOCK_TYPE, WHERE, self._on_where, qos_profile_default)

    def _on_where(self, msg: Any) -> None:
        self.leads_ns.append(self.executor.now().nanoseconds
                             - Time.from_msg(msg.clock).nanoseconds)

    def run(self, limit_s: float, stop: Callable[[], bool],
            tick: Callable[[int], None] | None = None,
            tick_hz: float = 1000.0) -> SimulationResult:
        step_ns = round(1e9 / tick_hz)
        t_ns = self.executor.now().nanoseconds
        end_ns = t_ns + round(limit_s * 1e9)
        while t_ns < end_ns and not stop():
            t_ns += step_ns
            self.executor.spin_until(t_ns)
            if tick is not None:
                tick(t_ns)
        if not self.leads_ns:
            return SimulationResult(1, "the slow node never said where it is")
        return SimulationResult(0, f"max lead {max(self.leads_ns)} ns over "
                                   f"{len(self.leads_ns)} reports")


def world(executor: DeterministicExecutor) -> BareWorld:
    return BareWorld(executor)
