"""A hover over the SITL with the companion's flight stack, to fly a fault into: the
shortest flight that shows how the FCU and the flight-control layer react (no cameras,
no mission). Shared by the fault-reaction flight tests."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

import interfaces
from flight_control.flight_control_node import ARM, REACH, TAKEOFF, FlightControlNode
from interfaces.px4 import NavigationState
from quadmission.assembly.companion import Companion, start_companion
from runtime import ActionClient, GoalStatus, Node
from runtime.future import Future
from sim.fault_spec import Fault
from sim.faults import FaultSwitches, install_faults
from sim.fcu.sitl import Sitl, build_sitl
from sim.scene import quad_state
from sim.world import Part, Scene, StopWhen, WorldResult

HOVER_Z_M = 1.5  # m above the floor


class Pilot(Node):
    """Arms, takes off and sends reaches through ``/flight_control`` (as the mission does)."""

    def __init__(self, sitl: Sitl, **kwargs: Any) -> None:
        super().__init__("fault_pilot", **kwargs)
        self.sitl = sitl
        self.arm = self.create_client(ARM, "/flight_control/arm")
        self.takeoff = ActionClient(self, TAKEOFF, "/flight_control/takeoff")
        self.reach = ActionClient(self, REACH, "/flight_control/reach")

    def t(self) -> float:
        return self.now().nanoseconds / 1e9

    def wait(self, future: Future[Any], limit_s: float) -> Any:
        self.sitl.run(limit_s, stop=StopWhen(future.done))
        assert future.done(), f"no answer within {limit_s} s of simulated time"
        return future.result()

    def goal(self, client: ActionClient, goal: Any, limit_s: float = 20.0) -> Any:
        handle = self.wait(client.send_goal_async(goal), 2.0)
        assert handle.accepted
        return self.wait(handle.get_result_async(), limit_s)

    def reach_to(self, x: float, y: float, z: float, limit_s: float = 20.0) -> Any:
        goal = interfaces.new(REACH.Goal, radius=0.2, stop_at_target=True)
        goal.target.position = interfaces.new("geometry_msgs/msg/Point", x=x, y=y, z=z)
        return self.goal(self.reach, goal, limit_s)


@dataclass
class FcuModes:
    """A world part that notes the FCU's navigation states as they change (truth)."""

    sitl: Sitl
    name: str = "fcu_modes"
    rate_hz: float = 50.0
    changes: list[tuple[float, NavigationState, bool]] = field(default_factory=list)
    eph_m: list[float] = field(default_factory=list)
    """The estimator's horizontal accuracy at each change [m]."""

    def update(self, t_ns: int, scene: Scene) -> None:
        st = self.sitl.firmware.status
        if st is None:
            return
        now = (st.nav_state, st.arming_state.name == "ARMED")
        if not self.changes or self.changes[-1][1:] != now:
            self.changes.append((t_ns / 1e9, *now))
            self.eph_m.append(self.sitl.firmware.estimator.eph())

    def first(self, nav: NavigationState, after_s: float = 0.0) -> float | None:
        return next((t for t, n, _ in self.changes if n is nav and t >= after_s), None)


@dataclass
class Hover:
    sitl: Sitl
    pilot: Pilot
    companion: Companion
    modes: FcuModes

    @property
    def flight_control(self) -> FlightControlNode:
        assert self.companion.flight_control is not None
        return self.companion.flight_control

    def t(self) -> float:
        return self.pilot.t()

    def position(self) -> np.ndarray:
        return np.array(quad_state(self.sitl.scene.data, self.sitl.scene.index).position)

    def speed(self) -> float:
        data = self.sitl.scene.data
        return float(np.linalg.norm(quad_state(data, self.sitl.scene.index).velocity))

    def inject(self, *faults: Fault) -> FaultSwitches | None:
        return install_faults(self.sitl, faults)

    def fly(self, seconds: float, part: Part | None = None) -> WorldResult:
        if part is not None:
            self.sitl.extra_parts.append(part)
        return self.sitl.run(seconds)


def hover(seed: int = 21) -> Hover:
    """Armed, in offboard, holding at HOVER_Z_M over the start pad (about 12 s simulated)."""
    sitl = build_sitl(seed=seed)
    companion = start_companion(sitl)
    fc = companion.flight_control
    assert fc is not None
    pilot = Pilot(sitl, context=sitl.executor.context)
    sitl.executor.add_node(pilot)
    modes = FcuModes(sitl)
    sitl.extra_parts.append(modes)

    def ready() -> bool:
        state = fc.vehicle_state()
        return state is not None and state.position_valid

    sitl.run(8.0, stop=StopWhen(ready))
    assert ready(), "no valid position from the FCU within 8 s"
    armed = pilot.wait(pilot.arm.call_async(interfaces.new(ARM.Request)), 8.0)
    assert armed.success, armed.message
    took_off = pilot.goal(pilot.takeoff, interfaces.new(TAKEOFF.Goal, altitude=HOVER_Z_M))
    assert took_off.status == GoalStatus.SUCCEEDED
    return Hover(sitl, pilot, companion, modes)
