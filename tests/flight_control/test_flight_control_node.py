"""The flight-control node in the loop: SITL flight controller, FCU bridge, VIO.

A pilot node talks to ``/flight_control/*`` only (as the navigator and the FSM will), and
the flights are judged on the simulator's ground truth. One flight (module fixture) is
shared by the tests that read it, to keep the suite short: preflight health, a goal
before arming, arm, takeoff to 1.5 m, four reaches, an out-of-field goal, a canceled
reach, land. The heartbeat-loss test flies on its own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pytest

import interfaces
from flight_control.flight_control_node import (
    ARM,
    LAND,
    REACH,
    TAKEOFF,
    TURN,
    FlightControlNode,
)
from flight_control.frames import quat_to_yaw
from navigation.params import NavigatorParams
from quadmission.assembly.companion import start_companion
from runtime import ActionClient, GoalStatus, Node, qos_profile_default
from runtime.future import Future
from runtime.parameters import load_parameters
from sim.fcu.sitl import Sitl, build_sitl
from sim.scene import quad_state
from sim.world import StopWhen

WAYPOINTS = [(3.5, 1.5, 1.5), (3.5, 3.5, 2.0), (1.5, 3.5, 1.5), (1.5, 1.5, 1.5)]
RADIUS = 0.15  # m




class Pilot(Node):
    """Uses the flight-control layer's services and actions; watches /fcu/status."""

    def __init__(self, sitl: Sitl, **kwargs: Any) -> None:
        super().__init__("pilot", **kwargs)
        self.sitl = sitl
        self.arm_client = self.create_client(ARM, "/flight_control/arm")
        self.takeoff = ActionClient(self, TAKEOFF, "/flight_control/takeoff")
        self.reach = ActionClient(self, REACH, "/flight_control/reach")
        self.land = ActionClient(self, LAND, "/flight_control/land")
        self.turn = ActionClient(self, TURN, "/flight_control/turn")
        self.health: list[Any] = []
        self.status: list[tuple[float, Any]] = []
        self.create_subscription("quadmission_interfaces/msg/HealthReport",
                                 "/flight_control/health", self.health.append,
                                 qos_profile_default)
        self.create_subscription("quadmission_interfaces/msg/FcuStatus", "/fcu/status",
                                 lambda m: self.status.append((self.t(), m)),
                                 qos_profile_default)

    def t(self) -> float:
        return self.now().nanoseconds / 1e9

    def run_until(self, future: Future[Any], limit_s: float) -> Any:
        self.sitl.run(limit_s, stop=StopWhen(future.done))
        assert future.done(), f"no answer within {limit_s} s of simulated time"
        return future.result()

    def send(self, client: ActionClient, goal: Any,
             feedback: list[Any] | None = None) -> Any:
        """The goal handle, once the server has accepted or rejected it."""
        cb = None if feedback is None else (lambda m: feedback.append(m.feedback))
        return self.run_until(client.send_goal_async(goal, feedback_callback=cb), 2.0)

    def outcome(self, handle: Any, limit_s: float = 30.0) -> Any:
        """GetResult's response (``.status``, ``.result``)."""
        return self.run_until(handle.get_result_async(), limit_s)

    def truth(self) -> np.ndarray:
        return np.array(quad_state(self.sitl.scene.data, self.sitl.scene.index).position)

    def truth_yaw(self) -> float:
        data = self.sitl.scene.data
        return float(quat_to_yaw(quad_state(data, self.sitl.scene.index).quaternion))

    def truth_speed(self) -> float:
        data = self.sitl.scene.data
        return float(np.linalg.norm(quad_state(data, self.sitl.scene.index).velocity))


def reach_goal(x: float, y: float, z: float, radius: float = RADIUS) -> Any:
    goal = interfaces.new(REACH.Goal, radius=radius, stop_at_target=True)
    goal.target.position = interfaces.new("geometry_msgs/msg/Point", x=x, y=y, z=z)
    return goal


def _setup(seed: int) -> tuple[Sitl, FlightControlNode, Pilot]:
    sitl = build_sitl(seed=seed)
    fc = start_companion(sitl).flight_control
    assert fc is not None
    pilot = Pilot(sitl, context=sitl.executor.context)

    def ready() -> bool:
        state = fc.vehicle_state()
        return state is not None and state.position_valid and len(pilot.health) > 0

    sitl.run(8.0, stop=StopWhen(ready))
    assert ready(), "no valid position from the FCU within 8 s"
    return sitl, fc, pilot


def _arm_and_take_off(pilot: Pilot, altitude: float) -> tuple[Any, Any, list[Any]]:
    arm = pilot.run_until(pilot.arm_client.call_async(interfaces.new(ARM.Request)), 8.0)
    assert arm.success, arm.message
    feedback: list[Any] = []
    handle = pilot.send(pilot.takeoff, interfaces.new(TAKEOFF.Goal, altitude=altitude),
                        feedback)
    assert handle.accepted
    return arm, pilot.outcome(handle, 20.0), feedback


@dataclass
class Flight:
    """What the shared flight recorded."""

    preflight_health: Any = None
    unarmed_reason: str = ""
    arm: Any = None
    takeoff: Any = None
    takeoff_feedback: list[Any] = field(default_factory=list)
    home: np.ndarray | None = None
    reaches: list[tuple[Any, np.ndarray, list[Any], float]] = field(default_factory=list)
    turn: Any = None
    yaw_before_turn: float = 0.0
    turn_truth_yaw: float = 0.0
    outside_reason: str = ""
    outside_moved: float = 0.0
    cancel: Any = None
    cancel_speed_at: float = 0.0
    cancel_speeds_after: list[float] = field(default_factory=list)
    cancel_drift: float = 0.0
    land: Any = None
    landed_truth: np.ndarray | None = None


@pytest.fixture(scope="module")
def flight() -> Flight:
    rec = Flight()
    sitl, _, pilot = _setup(seed=11)
    reports = len(pilot.health)
    sitl.run(1.5, stop=StopWhen(lambda: len(pilot.health) > reports))  # one with a position
    rec.preflight_health = pilot.health[-1]
    # a reach before arming is refused
    handle = pilot.send(pilot.reach, reach_goal(3.0, 1.5, 1.5))
    assert not handle.accepted
    rec.unarmed_reason = pilot.outcome(handle).result.message
    rec.home = pilot.truth()
    rec.arm, rec.takeoff, rec.takeoff_feedback = _arm_and_take_off(pilot, 1.5)
    for x, y, z in WAYPOINTS:
        feedback: list[Any] = []
        t0 = pilot.t()
        handle = pilot.send(pilot.reach, reach_goal(x, y, z), feedback)
        assert handle.accepted
        outcome = pilot.outcome(handle)
        rec.reaches.append((outcome, pilot.truth(), feedback, pilot.t() - t0))
    # a quarter turn to the left, on the spot
    rec.yaw_before_turn = pilot.truth_yaw()
    handle = pilot.send(pilot.turn, interfaces.new(TURN.Goal, yaw=math.pi / 2, relative=True))
    assert handle.accepted
    rec.turn = pilot.outcome(handle, 10.0)
    rec.turn_truth_yaw = pilot.truth_yaw()
    # outside the field: rejected, and the vehicle stays where it is
    before = pilot.truth()
    handle = pilot.send(pilot.reach, reach_goal(25.0, 3.0, 1.5))
    assert not handle.accepted
    rec.outside_reason = pilot.outcome(handle).result.message
    sitl.run(0.5)
    rec.outside_moved = float(np.linalg.norm(pilot.truth() - before))
    # a long reach east, canceled at cruise speed
    handle = pilot.send(pilot.reach, reach_goal(7.0, 1.5, 1.5))
    assert handle.accepted
    sitl.run(3.0)
    rec.cancel_speed_at = pilot.truth_speed()
    pilot.run_until(handle.cancel_goal_async(), 1.0)
    rec.cancel = pilot.outcome(handle, 5.0)
    sitl.run(2.0)  # braking
    held = pilot.truth()
    for _ in range(10):  # then one second of hold, sampled
        sitl.run(0.1)
        rec.cancel_speeds_after.append(pilot.truth_speed())
    rec.cancel_drift = float(np.linalg.norm(pilot.truth() - held))
    # land and disarm
    handle = pilot.send(pilot.land, interfaces.new(LAND.Goal, disarm=True))
    assert handle.accepted
    rec.land = pilot.outcome(handle, 30.0)
    rec.landed_truth = pilot.truth()
    return rec


def test_preflight_health_report_says_fcu_connected_and_position_valid(flight: Flight) -> None:
    report = flight.preflight_health
    module = report.modules[0]
    values = {kv.key: kv.value for kv in module.values}
    assert module.name == "flight_control"
    assert report.level == module.LEVEL_OK, module.message
    assert values["connected"] == "true" and values["position_valid"] == "true"
    assert values["armed"] == "false"


def test_goals_are_rejected_before_arming(flight: Flight) -> None:
    assert flight.unarmed_reason == "not armed"


def test_takeoff_to_1_5_m_reach_four_waypoints_each_within_its_radius_and_land(
        flight: Flight) -> None:
    assert flight.arm.message.startswith("armed in offboard")
    takeoff = flight.takeoff
    assert takeoff.status == GoalStatus.SUCCEEDED, takeoff.result.message
    assert flight.home is not None
    assert takeoff.result.position.z - flight.home[2] == pytest.approx(1.5, abs=RADIUS)
    distances = [fb.distance_left for fb in flight.takeoff_feedback]
    assert distances[0] > 1.0 and distances[-1] < 0.3
    for (outcome, truth, feedback, _), target in zip(flight.reaches, WAYPOINTS, strict=True):
        assert outcome.status == GoalStatus.SUCCEEDED, outcome.result.message
        assert outcome.result.result == outcome.result.RESULT_OK
        assert outcome.result.distance_error <= RADIUS  # what the node measured
        error = float(np.linalg.norm(truth - np.array(target)))
        assert error <= RADIUS, f"{target}: {error:.3f} m from the target (truth)"
        left = [fb.distance_left for fb in feedback]
        assert left[0] > 1.5 and min(left) <= RADIUS, "distance_left must count down"
    land = flight.land
    assert land.status == GoalStatus.SUCCEEDED, land.result.message
    assert flight.landed_truth is not None and flight.landed_truth[2] < 0.2


def test_turn_to_a_heading(flight: Flight) -> None:
    assert flight.turn.status == GoalStatus.SUCCEEDED, flight.turn.result.message
    turned = math.remainder(flight.turn_truth_yaw - flight.yaw_before_turn, 2 * math.pi)
    assert turned == pytest.approx(math.pi / 2, abs=0.08)


def test_reach_outside_the_field_is_rejected_with_the_reason(flight: Flight) -> None:
    assert flight.outside_reason == (
        "target (25.0, 3.0, 1.5) m is outside the flyable volume [0.4, 19.6] x [0.4, 13.6] x "
        "[0, 3.6] m")
    assert flight.outside_moved < 0.05


def test_cancel_stops_the_vehicle_and_holds_it(flight: Flight) -> None:
    assert flight.cancel_speed_at > 0.8, "the reach should be cruising when canceled"
    assert flight.cancel.status == GoalStatus.CANCELED
    assert flight.cancel.result.result == flight.cancel.result.RESULT_CANCELED
    assert max(flight.cancel_speeds_after) < 0.1
    assert flight.cancel_drift < 0.05
    # stopped well short of the goal at x = 7
    assert flight.cancel.result.position.x < 6.0


def test_losing_the_heartbeat_makes_the_fcu_hold_then_land() -> None:
    sitl, fc, pilot = _setup(seed=12)
    _, takeoff, _ = _arm_and_take_off(pilot, 1.0)
    assert takeoff.status == GoalStatus.SUCCEEDED
    lost_at = pilot.t()
    fc.destroy_node()  # the companion's flight control dies: no more setpoints

    def landing() -> bool:
        return any(t > lost_at and m.nav_state == m.NAV_STATE_AUTO_LAND
                   for t, m in pilot.status)

    result = sitl.run(10.0, stop=StopWhen(landing))
    assert result.crash is None
    after = [(t, m) for t, m in pilot.status if t > lost_at]
    hold_t = next(t for t, m in after if m.nav_state == m.NAV_STATE_AUTO_LOITER)
    land_t = next(t for t, m in after if m.nav_state == m.NAV_STATE_AUTO_LAND)
    assert 1.0 <= hold_t - lost_at <= 1.8  # COM_OF_LOSS_T = 1 s, + status period
    assert 4.5 <= land_t - hold_t <= 5.5  # held for COM_FAIL_ACT_T = 5 s, then lands
    assert any(m.failsafe and m.offboard_signal_lost for _, m in after)


def test_land_at_a_chosen_speed_descends_at_that_speed_then_disarms() -> None:
    _, _, pilot = _setup(seed=13)
    _, takeoff, _ = _arm_and_take_off(pilot, 1.5)
    assert takeoff.status == GoalStatus.SUCCEEDED
    too_slow = pilot.send(pilot.land, interfaces.new(LAND.Goal, speed=0.1, disarm=True))
    assert not too_slow.accepted
    rejected = pilot.outcome(too_slow, 2.0)
    assert "below 0.2 m/s" in rejected.result.message
    feedback: list[Any] = []
    handle = pilot.send(pilot.land, interfaces.new(LAND.Goal, speed=0.5, disarm=True), feedback)
    assert handle.accepted
    landed = pilot.outcome(handle, 30.0)
    assert landed.status == GoalStatus.SUCCEEDED, landed.result.message
    # the vertical speed reported while descending through the middle of the drop
    middle = [fb.vertical_speed for fb in feedback if 0.4 < fb.altitude < 1.1]
    assert middle and np.mean(middle) == pytest.approx(-0.5, abs=0.1)
    assert pilot.truth()[2] < 0.2
    assert not pilot.status[-1][1].armed


@pytest.mark.parametrize("speed", [1.0, 2.0])
def test_a_point_passed_at_speed_is_stopped_within_the_navigators_room_past_it(
        speed: float) -> None:
    """A reach that passes its target (``stop_at_target`` false) then holds it: the vehicle
    carries on past the point and comes back, stopping within ``speed`` times the
    navigator's ``pass_stop_s``, the room it wants clear past a lane point before it passes
    it at speed (random arena 149's arms hit a wall 0.49 m past one)."""
    sitl, _, pilot = _setup(seed=17)
    _, takeoff, _ = _arm_and_take_off(pilot, 1.5)
    assert takeoff.status == GoalStatus.SUCCEEDED
    target = pilot.truth() + np.array([4.0, 0.0, 0.0])
    goal = reach_goal(*target, radius=0.3)
    goal.stop_at_target, goal.speed = False, speed
    handle = pilot.send(pilot.reach, goal)
    assert handle.accepted
    passed = pilot.outcome(handle, 20.0)
    assert passed.status == GoalStatus.SUCCEEDED, passed.result.message
    assert pilot.truth_speed() > 0.8 * speed  # passed, not stopped at
    past: list[float] = []  # m beyond the point, along the reach, for 3 s of the hold
    for _ in range(30):
        sitl.run(0.1)
        past.append(float(pilot.truth()[0] - target[0]))
    room = speed * load_parameters(NavigatorParams, "navigator").pass_stop_s
    assert 0.05 * speed < max(past) <= room
    assert abs(past[-1]) < 0.05  # back on the point, held
