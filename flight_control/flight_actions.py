"""The four motion actions of ``flight_control`` (takeoff, reach, turn, land): how each
goal message becomes a behaviour, its feedback a message, its end a Result. Everything
they share is in :mod:`flight_control.behaviour_server`."""

from __future__ import annotations

import math
from typing import Any, Protocol

import numpy as np

import interfaces
from flight_control.behaviour_server import MotionAction, Needs, Vehicle
from flight_control.behaviours import (
    Land,
    LandFeedback,
    Observation,
    Reach,
    ReachFeedback,
    Setpoint,
    Takeoff,
    TakeoffFeedback,
    Turn,
    TurnFeedback,
)
from flight_control.frames import quat_to_yaw, wrap_pi
from flight_control.goal_checks import (
    FieldBounds,
    GoalError,
    GoalProblem,
    check_speed,
    check_takeoff_altitude,
    check_target,
    fmt_m,
)
from flight_control.params import FlightControlParams
from flight_control.policy import Outcome
from flight_control.setpoints import FloatArray
from interfaces import graph

TAKEOFF = graph.TAKEOFF.interface()
LAND = graph.LAND.interface()
REACH = graph.REACH.interface()
TURN = graph.TURN.interface()


class Flight(Vehicle, Protocol):
    """What the actions read from the node."""

    params: FlightControlParams
    bounds: FieldBounds
    position: FloatArray | None  # m, map frame; None before the first odometry
    home: FloatArray | None  # m, the take-off point


def xyz(p: FloatArray) -> str:
    return f"({fmt_m(float(p[0]))}, {fmt_m(float(p[1]))}, {fmt_m(float(p[2]))}) m"


def _codes(ok: str, canceled: str, timeout: str, lost: str,
           rejected: str) -> dict[Outcome, str]:
    return {Outcome.SUCCEEDED: ok, Outcome.CANCELED: canceled, Outcome.PREEMPTED: canceled,
            Outcome.TIMEOUT: timeout, Outcome.LOST_CONTROL: lost, Outcome.FCU_REJECTED: rejected}


def takeoff_home(fc: Flight) -> FloatArray | None:
    """The take-off point for a new takeoff: where the vehicle is when it stands on the
    ground (or before any), else the last take-off point. A node that never saw the
    take-off (restarted with the vehicle in the air) takes the floor under the vehicle: a
    take-off from where it hovers would climb a take-off altitude above it (a flight
    control restarted at 1.6 m climbed to 3.1 m, near the ceiling, and no path could start
    there)."""
    if fc.position is None:
        return fc.home
    state = fc.vehicle_state()
    if state is not None and state.landed:
        return fc.position.copy()
    if fc.home is None:
        home = fc.position.copy()
        if state is not None and state.armed:  # in the air, its take-off unseen
            home[2] = fc.bounds.lower[2]
        return home
    return fc.home


def takeoff(fc: Flight) -> MotionAction:
    p = fc.params

    def check(goal: Any) -> GoalProblem | None:
        home = takeoff_home(fc)
        return check_speed(goal.speed, p.max_speed) or check_takeoff_altitude(
            goal.altitude or p.takeoff_altitude, 0.0 if home is None else float(home[2]),
            fc.bounds, p.min_altitude)

    def start(goal: Any, obs: Observation, sp: Setpoint) -> Takeoff:
        fc.home = takeoff_home(fc)
        assert fc.home is not None
        state = fc.vehicle_state()
        # in the air (a mission resumed after the FCU's failsafe flew): in place
        airborne = state is not None and state.armed and not state.landed
        return Takeoff(sp, obs.position, fc.home, altitude=goal.altitude or p.takeoff_altitude,
                       speed=goal.speed or p.takeoff_speed, radius=p.reach_radius,
                       tuning=p.reach_tuning(), mode_wait_s=p.mode_wait_s,
                       over=obs.position if airborne else None)

    def feedback(f: TakeoffFeedback) -> Any:
        return interfaces.new(TAKEOFF.Feedback, altitude=f.altitude,
                              distance_left=f.distance_left)

    def finish(goal: Any, result: Any, obs: Observation) -> str:
        result.position = interfaces.point(*obs.position)
        home = fc.home if fc.home is not None else obs.position
        return (f"at {fmt_m(float(obs.position[2] - home[2]))} m above the take-off point "
                f"{xyz(home)}")

    return MotionAction(TAKEOFF, "takeoff", Needs(armed=True), check, start, feedback, finish,
                        _codes("RESULT_OK", "RESULT_CANCELED", "RESULT_TIMEOUT",
                               "RESULT_FCU_REJECTED", "RESULT_FCU_REJECTED"))


def reach(fc: Flight) -> MotionAction:
    p = fc.params

    def target_of(goal: Any) -> FloatArray:
        t = goal.target.position
        return np.array([t.x, t.y, t.z], dtype=np.float64)

    def check(goal: Any) -> GoalProblem | None:
        return (check_target(target_of(goal), fc.bounds, p.min_altitude)
                or check_speed(goal.speed, p.max_speed))

    def start(goal: Any, obs: Observation, sp: Setpoint) -> Reach:
        o = goal.target.orientation
        q = np.array([o.w, o.x, o.y, o.z])
        target_yaw = float(quat_to_yaw(q / np.linalg.norm(q))) if np.any(q) else None
        return Reach.toward(sp, obs.position, target_of(goal),
                            speed=goal.speed or p.cruise_speed,
                            radius=goal.radius or p.reach_radius, tuning=p.reach_tuning(),
                            stop_at_target=goal.stop_at_target, target_yaw=target_yaw,
                            velocity=obs.velocity)

    def feedback(f: ReachFeedback) -> Any:
        return interfaces.new(REACH.Feedback, position=interfaces.point(*f.position),
                              distance_left=f.distance_left)

    def finish(goal: Any, result: Any, obs: Observation) -> str:
        target = target_of(goal)
        error = float(np.linalg.norm(obs.position - target))
        result.position = interfaces.point(*obs.position)
        result.distance_error = error
        radius = goal.radius or p.reach_radius
        verb = "reached" if error <= radius else "stopped"
        return f"{verb} {fmt_m(error)} m from {xyz(target)} (radius {fmt_m(radius)} m)"

    return MotionAction(REACH, "reach", Needs(armed=True, flying=True, offboard=True), check,
                        start, feedback, finish,
                        _codes("RESULT_OK", "RESULT_CANCELED", "RESULT_TIMEOUT",
                               "RESULT_NOT_FLYING", "RESULT_NOT_FLYING"))


def turn(fc: Flight) -> MotionAction:
    p = fc.params

    def check(goal: Any) -> GoalProblem | None:
        if not math.isfinite(goal.yaw):
            return GoalProblem(GoalError.NOT_FINITE, f"yaw {goal.yaw} is not finite")
        return check_speed(goal.yaw_rate, p.max_yaw_rate)

    def start(goal: Any, obs: Observation, sp: Setpoint) -> Turn:
        target = sp.yaw + goal.yaw if goal.relative else goal.yaw
        return Turn(sp, target_yaw=wrap_pi(target), rate=goal.yaw_rate or p.yaw_rate,
                    tolerance=p.yaw_tolerance)

    def feedback(f: TurnFeedback) -> Any:
        return interfaces.new(TURN.Feedback, yaw=f.yaw, angle_left=f.angle_left)

    def finish(goal: Any, result: Any, obs: Observation) -> str:
        result.yaw = obs.yaw
        return f"heading {obs.yaw:.3f} rad"

    return MotionAction(TURN, "turn", Needs(armed=True, flying=True, offboard=True), check,
                        start, feedback, finish,
                        _codes("RESULT_OK", "RESULT_CANCELED", "RESULT_TIMEOUT",
                               "RESULT_NOT_FLYING", "RESULT_NOT_FLYING"))


def land(fc: Flight) -> MotionAction:
    p = fc.params

    def check(goal: Any) -> GoalProblem | None:
        if 0.0 < goal.speed < p.min_land_speed:
            return GoalProblem(GoalError.TOO_SLOW,
                               f"land speed {goal.speed} m/s is below {p.min_land_speed} m/s: "
                               "the FCU's land detector would not see a descent")
        return check_speed(goal.speed, p.max_speed)

    def start(goal: Any, obs: Observation, sp: Setpoint) -> Land:
        home_z = float(fc.home[2]) if fc.home is not None else 0.0
        return Land(sp, obs.position, speed=goal.speed, disarm=goal.disarm, home_z=home_z)

    def feedback(f: LandFeedback) -> Any:
        return interfaces.new(LAND.Feedback, altitude=f.altitude,
                              vertical_speed=f.vertical_speed)

    def finish(goal: Any, result: Any, obs: Observation) -> str:
        result.position = interfaces.point(*obs.position)
        verb = "landed" if obs.landed else "stopped"
        return f"{verb} at {xyz(obs.position)}"

    return MotionAction(LAND, "land", Needs(armed=True, battery=False), check, start, feedback,
                        finish, _codes("RESULT_OK", "RESULT_CANCELED", "RESULT_TIMEOUT",
                                       "RESULT_FCU_REJECTED", "RESULT_FCU_REJECTED"),
                        timeout_s=p.land_timeout_s)


def motion_actions(fc: Flight) -> list[MotionAction]:
    return [takeoff(fc), reach(fc), turn(fc), land(fc)]


__all__ = ["LAND", "REACH", "TAKEOFF", "TURN", "Flight", "motion_actions", "xyz"]
