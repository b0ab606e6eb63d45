"""What every flight behaviour shares: the observation it reads, the step it returns, the
outcomes it can end with (:data:`BEHAVIOUR_OUTCOMES`, in the words of
:mod:`flight_control.policy`), and the FCU commands it may ask for. Pure (numpy only).

A behaviour is an object built for one goal whose ``step(observation, now_ns)`` is called
at the setpoint rate by :class:`flight_control.behaviour_server.BehaviourServer`. It
returns the setpoint to stream, the feedback, and ``outcome`` None while it runs. When it
needs the FCU to do something (a mode change, NAV_LAND, disarm) it asks with
``Step.command``; the server runs the command protocol and puts the answer in the next
observation's ``reply``. Goal timeouts, cancel and preemption are the server's, not the
behaviour's (as in Aerostack2's ``as2_behavior``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Generic, Protocol, TypeVar

import numpy as np

from flight_control.goal_checks import VehicleState
from flight_control.policy import Outcome
from flight_control.setpoints import FloatArray
from interfaces.px4 import (
    FORCE_ARM_DISARM_MAGIC,
    MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
    Px4CustomMainMode,
    VehicleCmd,
)

#: How a flight-control goal can end. Behaviours end with SUCCEEDED, LOST_CONTROL or
#: FCU_REJECTED; the server adds TIMEOUT, CANCELED and PREEMPTED (a newer motion goal).
BEHAVIOUR_OUTCOMES = frozenset({Outcome.SUCCEEDED, Outcome.LOST_CONTROL, Outcome.FCU_REJECTED,
                                Outcome.TIMEOUT, Outcome.CANCELED, Outcome.PREEMPTED})


@dataclass(frozen=True, eq=False)
class Setpoint:
    """What the stream sends: position [m], velocity feed-forward [m/s], yaw [rad]; ENU
    map frame. A NaN position axis is not controlled (the velocity is)."""

    position: FloatArray
    velocity: FloatArray
    yaw: float

    @classmethod
    def hold(cls, position: FloatArray, yaw: float) -> Setpoint:
        """Stay at ``position`` with heading ``yaw``."""
        return cls(np.array(position, dtype=np.float64), np.zeros(3), float(yaw))


@dataclass(frozen=True)
class CommandRequest:
    """An FCU command a behaviour asks for (PX4 ``VEHICLE_CMD_*`` and its parameters)."""

    command: VehicleCmd
    param1: float = 0.0
    param2: float = 0.0


#: Switch to offboard control.
OFFBOARD = CommandRequest(VehicleCmd.DO_SET_MODE, float(MAV_MODE_FLAG_CUSTOM_MODE_ENABLED),
                          float(Px4CustomMainMode.OFFBOARD))
#: The FCU's own landing (PX4's MPC_LAND_SPEED, then its land detector).
NAV_LAND = CommandRequest(VehicleCmd.NAV_LAND)


def arm_disarm(arm: bool, *, force: bool = False) -> CommandRequest:
    """Arm (``param1`` 1) or disarm (0); ``force`` skips the FCU's checks (PX4's magic
    ``param2``): arming without pre-arm checks, or a kill in flight."""
    return CommandRequest(VehicleCmd.COMPONENT_ARM_DISARM, 1.0 if arm else 0.0,
                          float(FORCE_ARM_DISARM_MAGIC) if force else 0.0)


#: Disarm, with the FCU's checks (it refuses in flight).
DISARM = arm_disarm(False)


@dataclass(frozen=True)
class CommandReply:
    """The FCU's answer to a :class:`CommandRequest`: accepted or not, and a sentence."""

    request: CommandRequest
    accepted: bool
    message: str


@dataclass(frozen=True, eq=False)
class Observation:
    """What a behaviour sees at one step: position [m] and velocity [m/s] in the ENU map
    frame, heading [rad], the FCU's state (None: /fcu/status is stale), and the answer to
    the behaviour's last command request (None until it comes)."""

    position: FloatArray
    velocity: FloatArray
    yaw: float
    vehicle: VehicleState | None
    reply: CommandReply | None = None

    @property
    def in_control(self) -> bool:
        """Armed and in offboard: our setpoints fly the vehicle."""
        v = self.vehicle
        return v is not None and v.armed and v.offboard

    @property
    def landed(self) -> bool:
        return self.vehicle is not None and self.vehicle.landed

    @property
    def armed(self) -> bool:
        return self.vehicle is not None and self.vehicle.armed


F = TypeVar("F", covariant=True)


@dataclass(frozen=True, eq=False)
class Step(Generic[F]):
    """One step's output: the setpoint to stream (None: leave the stream alone), the
    feedback, the outcome (None: still running), an FCU command to run before the next
    step, and the reason for a failure outcome."""

    setpoint: Setpoint | None
    feedback: F
    outcome: Outcome | None = None
    command: CommandRequest | None = None
    reason: str = ""


class Behaviour(Protocol[F]):
    """A flight behaviour for one goal."""

    @property
    def expected_s(self) -> float | None:
        """How long the goal should take [s] when all goes well; None: no model (the
        server uses the action's fixed timeout)."""
        ...

    def step(self, observation: Observation, now_ns: int) -> Step[F]:
        """Advance to ``now_ns`` (int nanoseconds, monotonic) given ``observation``."""
        ...


def elapsed_s(last_ns: int | None, now_ns: int) -> float:
    """Seconds since ``last_ns`` (0 for the first step, or if time went backwards)."""
    return 0.0 if last_ns is None else max(0.0, (now_ns - last_ns) / 1e9)


__all__ = [
    "BEHAVIOUR_OUTCOMES",
    "DISARM",
    "NAV_LAND",
    "OFFBOARD",
    "Behaviour",
    "CommandReply",
    "CommandRequest",
    "Observation",
    "Setpoint",
    "Step",
    "arm_disarm",
    "elapsed_s",
]
