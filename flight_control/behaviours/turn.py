"""Turn: on the spot, ramp the yaw setpoint to a heading at a rate.

The setpoint holds the position it started from and turns the short way by at most
``rate`` [rad/s]. The goal succeeds when the setpoint is at the target heading and the
vehicle within ``tolerance`` of it. Leaving offboard control ends it with LOST_CONTROL.
"""

from __future__ import annotations

from dataclasses import dataclass

from flight_control.behaviours.base import Observation, Setpoint, Step, elapsed_s
from flight_control.frames import wrap_pi
from flight_control.policy import Outcome
from flight_control.setpoints import yaw_toward


@dataclass(frozen=True)
class TurnFeedback:
    yaw: float  # rad, the vehicle's heading
    angle_left: float  # rad, signed remaining turn, (-pi, pi]


class Turn:
    """One turn goal; see the module docstring."""

    def __init__(self, start: Setpoint, *, target_yaw: float, rate: float,
                 tolerance: float) -> None:
        if not rate > 0.0:
            raise ValueError(f"rate: {rate} rad/s must be > 0")
        self.position = start.position.copy()
        self.setpoint_yaw = wrap_pi(start.yaw)
        self.target = wrap_pi(target_yaw)
        self.rate = rate
        self.tolerance = tolerance
        self._expected_s = abs(wrap_pi(self.target - self.setpoint_yaw)) / rate
        self._last_ns: int | None = None

    @property
    def expected_s(self) -> float:
        return self._expected_s

    def step(self, observation: Observation, now_ns: int) -> Step[TurnFeedback]:
        left = wrap_pi(self.target - observation.yaw)
        feedback = TurnFeedback(observation.yaw, left)
        if not observation.in_control:
            return Step(None, feedback, Outcome.LOST_CONTROL)
        dt = elapsed_s(self._last_ns, now_ns)
        self._last_ns = now_ns
        self.setpoint_yaw = yaw_toward(self.setpoint_yaw, self.target, self.rate, dt)
        setpoint = Setpoint.hold(self.position, self.setpoint_yaw)
        if self.setpoint_yaw == self.target and abs(left) <= self.tolerance:
            return Step(setpoint, feedback, Outcome.SUCCEEDED)
        return Step(setpoint, feedback)


__all__ = ["Turn", "TurnFeedback"]
