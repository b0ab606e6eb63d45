"""Reach: fly a straight :class:`~flight_control.setpoints.ReachPlan` to a target.

The carrot of the plan is the setpoint. The goal succeeds when the carrot is at the end
and the vehicle is inside ``radius`` of the target; when the plan stops there, the
vehicle must also be slower than ``stop_speed`` for ``settle_s``. Then the setpoint holds
the target. Leaving offboard control ends it with LOST_CONTROL.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from flight_control.behaviours.base import Observation, Setpoint, Step, elapsed_s
from flight_control.policy import Outcome
from flight_control.setpoints import FloatArray, ReachPlan, ReachProgress


@dataclass(frozen=True)
class ReachTuning:
    """How reaches are flown (``config/flight_control.yaml``)."""

    spacing: float  # m, between intermediate setpoints
    acceleration: float  # m/s^2, carrot acceleration and braking
    waypoint_radius: float  # m, an intermediate setpoint is reached inside it
    stop_speed: float  # m/s, stopped at the target below this speed
    settle_s: float  # s, inside the radius and stopped this long = reached


@dataclass(frozen=True, eq=False)
class ReachFeedback:
    position: FloatArray  # m, where the vehicle is
    distance_left: float  # m, straight line to the target


class Reach:
    """One reach goal; see the module docstring."""

    def __init__(self, plan: ReachPlan, *, radius: float, stop_speed: float,
                 settle_s: float) -> None:
        self.plan = plan
        self.radius = radius
        self.stop_speed = stop_speed
        self.settle_ns = round(settle_s * 1e9)
        self.progress = ReachProgress()
        self._last_ns: int | None = None
        self._settled_since_ns: int | None = None

    @classmethod
    def toward(cls, start: Setpoint, position: npt.ArrayLike, target: npt.ArrayLike, *,
               speed: float, radius: float, tuning: ReachTuning, stop_at_target: bool = True,
               target_yaw: float | None = None,
               velocity: npt.ArrayLike | None = None) -> Reach:
        """From the vehicle's ``position`` to ``target`` at ``speed`` [m/s], turning from
        the streamed ``start`` setpoint's yaw to ``target_yaw`` (None: keep it). The
        carrot starts at the vehicle's ``velocity`` [m/s] along the segment (none
        backwards, at most ``speed``): a reach that follows one passed on the way goes on
        at the speed the vehicle has instead of braking to a start from rest."""
        plan = ReachPlan.build(position, target, spacing=tuning.spacing, cruise_speed=speed,
                               acceleration=tuning.acceleration,
                               waypoint_radius=tuning.waypoint_radius,
                               stop_at_target=stop_at_target, start_yaw=start.yaw,
                               target_yaw=target_yaw)
        reach = cls(plan, radius=radius, stop_speed=tuning.stop_speed,
                    settle_s=tuning.settle_s)
        if velocity is not None:
            along = float(np.dot(np.asarray(velocity, dtype=np.float64), plan.direction))
            reach.progress = ReachProgress(speed=min(max(along, 0.0), plan.cruise_speed))
        return reach

    @property
    def expected_s(self) -> float:
        return self.plan.expected_duration()

    def step(self, observation: Observation, now_ns: int) -> Step[ReachFeedback]:
        position = observation.position
        distance = float(np.linalg.norm(position - self.plan.target))
        feedback = ReachFeedback(position, distance)
        if not observation.in_control:
            return Step(None, feedback, Outcome.LOST_CONTROL)
        dt = elapsed_s(self._last_ns, now_ns)
        self._last_ns = now_ns
        self.progress = self.plan.advance(self.progress, position, dt)
        carrot = self.plan.carrot(self.progress)
        arrived = self.progress.s >= self.plan.length and distance <= self.radius
        if arrived and not self.plan.stop_at_target:  # passing through: no settling
            return self._done(feedback)
        if arrived and float(np.linalg.norm(observation.velocity)) <= self.stop_speed:
            if self._settled_since_ns is None:
                self._settled_since_ns = now_ns
            if now_ns - self._settled_since_ns >= self.settle_ns:
                return self._done(feedback)
        else:
            self._settled_since_ns = None
        return Step(Setpoint(carrot.position, carrot.velocity, carrot.yaw), feedback)

    def _done(self, feedback: ReachFeedback) -> Step[ReachFeedback]:
        return Step(Setpoint.hold(self.plan.target, self.plan.target_yaw), feedback,
                    Outcome.SUCCEEDED)


__all__ = ["Reach", "ReachFeedback", "ReachTuning"]
