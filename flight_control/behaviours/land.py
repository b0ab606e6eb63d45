"""Land: straight down where the vehicle is, until the FCU detects the touchdown; then
disarm when asked to.

``speed`` 0 is the FCU's own landing: the behaviour asks for NAV_LAND (PX4 descends at
its MPC_LAND_SPEED) and keeps streaming a hold setpoint that follows the vehicle down,
so a cancel can take offboard back at once. ``speed`` > 0 is an offboard descent at that
speed [m/s], holding x, y and the heading, the altitude left free. Once the FCU's land
detector reports the touchdown the goal succeeds, after a disarm request when ``disarm``
is set (SUCCEEDED as soon as the FCU reports the vehicle disarmed). A refused NAV_LAND
ends it with FCU_REJECTED, and so does a disarm refused ``DISARM_ATTEMPTS`` times (asked
again ``DISARM_RETRY_NS`` after a refusal, once the land detector says landed again): the
commander refuses a disarm while its land detector says "not landed", and the status the
behaviour saw can be a moment older than that, so a single refusal right after a touchdown
is no reason to stop.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from flight_control.behaviours.base import (
    DISARM,
    NAV_LAND,
    CommandReply,
    Observation,
    Setpoint,
    Step,
)
from flight_control.policy import Outcome
from flight_control.setpoints import FloatArray

DISARM_ATTEMPTS = 3  # disarm requests before a refusal ends the landing
DISARM_RETRY_NS = 1_000_000_000  # ns between a refused disarm and the next request


@dataclass(frozen=True)
class LandFeedback:
    altitude: float  # m above the take-off point
    vertical_speed: float  # m/s, ENU z (negative while descending)


class Land:
    """One land goal; see the module docstring."""

    def __init__(self, start: Setpoint, position: FloatArray, *, speed: float, disarm: bool,
                 home_z: float) -> None:
        if not (math.isfinite(speed) and speed >= 0.0):
            raise ValueError(f"speed: {speed} m/s must be finite and >= 0")
        self.start = start
        self.speed = speed
        self.disarm = disarm
        self.home_z = home_z
        self.descend_at = position.copy()
        self._asked_land = False
        self._asked_disarm = False
        self._refusals = 0  # disarm refusals so far
        self._last_refusal: CommandReply | None = None  # seen again until the next ack
        self._refused_at_ns = 0

    @property
    def expected_s(self) -> None:
        return None  # the FCU decides the touchdown: the action's fixed timeout applies

    def step(self, observation: Observation, now_ns: int) -> Step[LandFeedback]:
        feedback = LandFeedback(float(observation.position[2]) - self.home_z,
                                float(observation.velocity[2]))
        hold = Setpoint.hold(observation.position, self.start.yaw)
        reply = observation.reply
        if self.speed == 0.0 and not self._asked_land:
            self._asked_land = True
            return Step(self.start, feedback, command=NAV_LAND)
        if reply is not None and not reply.accepted and reply.request == NAV_LAND:
            return Step(None, feedback, Outcome.FCU_REJECTED, reason=reply.message)
        if observation.landed:
            if not observation.armed:
                return Step(None, feedback, Outcome.SUCCEEDED)
            if not self.disarm:
                return Step(hold, feedback, Outcome.SUCCEEDED)
            if not self._asked_disarm:
                if self._refusals and now_ns - self._refused_at_ns < DISARM_RETRY_NS:
                    return Step(hold, feedback)
                self._asked_disarm = True
                return Step(hold, feedback, command=DISARM)
            if (reply is not None and reply.request == DISARM and not reply.accepted
                    and reply is not self._last_refusal):
                self._refusals += 1
                self._last_refusal = reply
                if self._refusals >= DISARM_ATTEMPTS:
                    return Step(hold, feedback, Outcome.FCU_REJECTED, reason=reply.message)
                self._asked_disarm = False  # ask again in a moment
                self._refused_at_ns = now_ns
            return Step(hold, feedback)  # disarm asked or accepted: until /fcu/status shows it
        if self.speed > 0.0:
            x, y = self.descend_at[:2]
            return Step(Setpoint(np.array([x, y, math.nan]), np.array([0.0, 0.0, -self.speed]),
                                 self.start.yaw), feedback)
        return Step(hold, feedback)


__all__ = ["Land", "LandFeedback"]
