"""Takeoff: take offboard control if the FCU is not in it, then climb straight up.

The climb is a :class:`~flight_control.behaviours.reach.Reach` from where the vehicle is
to ``altitude`` above the take-off point, above that point, or above ``over`` when given:
a vehicle already in the air (a mission resumed after the FCU's failsafe flew) takes
offboard back and climbs or sinks to the altitude where it is. Before the climb, when the
vehicle is armed but not in offboard, the behaviour asks for offboard mode; a refusal, or
the mode not showing in /fcu/status within ``mode_wait_s`` of the acceptance, ends it with
FCU_REJECTED.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flight_control.behaviours.base import OFFBOARD, Observation, Setpoint, Step
from flight_control.behaviours.reach import Reach, ReachTuning
from flight_control.policy import Outcome
from flight_control.setpoints import FloatArray


@dataclass(frozen=True)
class TakeoffFeedback:
    altitude: float  # m above the take-off point
    distance_left: float  # m to the target altitude


class Takeoff:
    """One takeoff goal; see the module docstring."""

    def __init__(self, start: Setpoint, position: FloatArray, home: FloatArray, *,
                 altitude: float, speed: float, radius: float, tuning: ReachTuning,
                 mode_wait_s: float, over: FloatArray | None = None) -> None:
        self.home = home.copy()
        self.target = self.home + np.array([0.0, 0.0, altitude])
        if over is not None:
            self.target[:2] = over[:2]
        self.start = start
        self.climb = Reach.toward(start, position, self.target, speed=speed, radius=radius,
                                  tuning=tuning)
        self.mode_wait_ns = round(mode_wait_s * 1e9)
        self._climbing = False
        self._asked = False
        self._accepted_ns: int | None = None

    @property
    def expected_s(self) -> float:
        return self.climb.expected_s

    def step(self, observation: Observation, now_ns: int) -> Step[TakeoffFeedback]:
        z = float(observation.position[2])
        feedback = TakeoffFeedback(z - float(self.home[2]), abs(float(self.target[2]) - z))
        if not self._climbing and observation.in_control:
            self._climbing = True
        if self._climbing:
            climb = self.climb.step(observation, now_ns)
            return Step(climb.setpoint, feedback, climb.outcome)
        if not self._asked:
            self._asked = True
            return Step(self.start, feedback, command=OFFBOARD)
        reply = observation.reply
        if reply is not None and not reply.accepted:
            return Step(self.start, feedback, Outcome.FCU_REJECTED, reason=reply.message)
        if reply is not None:
            if self._accepted_ns is None:
                self._accepted_ns = now_ns
            if now_ns - self._accepted_ns > self.mode_wait_ns:
                return Step(self.start, feedback, Outcome.FCU_REJECTED,
                            reason="offboard not entered")
        return Step(self.start, feedback)


__all__ = ["Takeoff", "TakeoffFeedback"]
