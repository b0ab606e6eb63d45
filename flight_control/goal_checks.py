"""Goal validation for the flight-control layer: pure, one place, typed reasons.

Every action and service of ``flight_control`` validates its goal here before it
touches the vehicle; a problem comes back as a :class:`GoalProblem` (what kind, and a
sentence that says what was wrong with the numbers), which the node turns into a
rejection with that sentence as the reason.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from enum import Enum

import numpy as np
import numpy.typing as npt

from interfaces.px4.constants import NavigationState

#: A goal rejected for want of a position estimate says this (a state that can pass: a
#: client may send the goal again).
NO_POSITION_MESSAGE = "no valid position estimate"


class GoalError(Enum):
    """Why a goal cannot be accepted."""

    NOT_FINITE = "not_finite"
    OUTSIDE_FIELD = "outside_field"
    BELOW_FLOOR = "below_floor"
    FCU_DISCONNECTED = "fcu_disconnected"
    NO_POSITION = "no_position"
    NOT_ARMED = "not_armed"
    ALREADY_ARMED = "already_armed"
    NOT_FLYING = "not_flying"
    ALREADY_FLYING = "already_flying"
    BATTERY_CRITICAL = "battery_critical"
    NOT_IN_CONTROL = "not_in_control"
    TOO_FAST = "too_fast"
    TOO_SLOW = "too_slow"


@dataclass(frozen=True)
class GoalProblem:
    """A goal's problem: its kind, and the reason to give the caller."""

    error: GoalError
    message: str


def fmt_m(value: float) -> str:
    """A length [m] for messages: two decimals at most, at least one (``25.0``, ``1.55``)."""
    text = f"{value:.2f}".rstrip("0")
    return text + "0" if text.endswith(".") else text


def _fmt_bound(value: float) -> str:
    return f"{value:g}"


@dataclass(frozen=True)
class FieldBounds:
    """The allowed flight volume, an axis-aligned box in the map frame [m]."""

    lower: tuple[float, float, float]
    upper: tuple[float, float, float]

    def __post_init__(self) -> None:
        if len(self.lower) != 3 or len(self.upper) != 3:
            raise ValueError(f"field bounds need 3 values each, got {self.lower}, {self.upper}")
        for axis, lo, hi in zip("xyz", self.lower, self.upper, strict=True):
            if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
                raise ValueError(f"field bounds on {axis}: need finite min < max, "
                                 f"got [{lo}, {hi}]")

    @classmethod
    def of(cls, lower: Sequence[float], upper: Sequence[float]) -> FieldBounds:
        lo = tuple(float(v) for v in lower)
        hi = tuple(float(v) for v in upper)
        if len(lo) != 3 or len(hi) != 3:
            raise ValueError(f"field bounds need 3 values each, got {list(lo)}, {list(hi)}")
        return cls((lo[0], lo[1], lo[2]), (hi[0], hi[1], hi[2]))

    def shrunk(self, clearance: float) -> FieldBounds:
        """The volume ``clearance`` [m] away from the walls and the ceiling (the floor
        stays: the floor rule is ``min_altitude``). ValueError if nothing is left."""
        lo, hi = self.lower, self.upper
        return FieldBounds((lo[0] + clearance, lo[1] + clearance, lo[2]),
                           (hi[0] - clearance, hi[1] - clearance, hi[2] - clearance))

    def contains(self, position: npt.ArrayLike) -> bool:
        p = np.asarray(position, dtype=np.float64)
        return bool(np.all(p >= np.asarray(self.lower)) and np.all(p <= np.asarray(self.upper)))

    def describe(self) -> str:
        """``[0, 20] x [0, 14] x [0, 4] m``."""
        return " x ".join(f"[{_fmt_bound(lo)}, {_fmt_bound(hi)}]"
                          for lo, hi in zip(self.lower, self.upper, strict=True)) + " m"


def _fmt_point(p: npt.ArrayLike) -> str:
    return "(" + ", ".join(fmt_m(float(v)) for v in np.asarray(p, dtype=np.float64)) + ") m"


def check_target(target: npt.ArrayLike, bounds: FieldBounds,
                 min_altitude: float) -> GoalProblem | None:
    """A reach target [m, map frame]: finite, inside the field, not below the floor."""
    p = np.asarray(target, dtype=np.float64)
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        return GoalProblem(GoalError.NOT_FINITE, f"target {p.tolist()} is not 3 finite numbers")
    if not bounds.contains(p):
        return GoalProblem(GoalError.OUTSIDE_FIELD,
                           f"target {_fmt_point(p)} is outside the flyable volume "
                           f"{bounds.describe()}")
    if p[2] < min_altitude:
        return GoalProblem(GoalError.BELOW_FLOOR,
                           f"target altitude {fmt_m(float(p[2]))} m is below the floor "
                           f"{fmt_m(min_altitude)} m")
    return None


@dataclass(frozen=True)
class VehicleState:
    """What the checks need to know about the vehicle (from /fcu/status)."""

    connected: bool
    armed: bool
    landed: bool
    position_valid: bool
    battery_warning: int  # px4 BatteryStatus.WARNING_* (0 none .. 3 emergency)
    offboard: bool = False  # the FCU is in offboard control
    nav_state: int = 0  # PX4 NAVIGATION_STATE_*, for messages


def battery_critical(warning: int, critical_warning: int) -> bool:
    """Whether the FCU's battery ``warning`` (px4 ``BatteryWarning``) is at or above the
    level ``critical_warning`` that rejects goals (landing excepted)."""
    return warning >= critical_warning


def nav_state_text(nav_state: int) -> str:
    """``DESCEND (nav_state 12)``: PX4's name with the number, so a message says what the
    FCU is doing."""
    try:
        return f"{NavigationState(nav_state).name} (nav_state {nav_state})"
    except ValueError:
        return f"nav_state {nav_state}"


def check_vehicle(state: VehicleState | None, *, battery_critical_warning: int | None,
                  need_armed: bool = False, need_disarmed: bool = False,
                  need_flying: bool = False, need_landed: bool = False,
                  need_offboard: bool = False) -> GoalProblem | None:
    """The vehicle can take the goal: FCU there, position, battery, arming and flight state
    as asked. Checked in that order, so the most basic problem is the one reported.
    ``battery_critical_warning`` None skips the battery (landing is always allowed)."""
    if state is None or not state.connected:
        return GoalProblem(GoalError.FCU_DISCONNECTED, "FCU not connected")
    if not state.position_valid:
        return GoalProblem(GoalError.NO_POSITION, NO_POSITION_MESSAGE)
    if battery_critical_warning is not None and battery_critical(state.battery_warning,
                                                                 battery_critical_warning):
        return GoalProblem(GoalError.BATTERY_CRITICAL,
                           f"battery critical (warning level {state.battery_warning})")
    if need_armed and not state.armed:
        return GoalProblem(GoalError.NOT_ARMED, "not armed")
    if need_disarmed and state.armed:
        return GoalProblem(GoalError.ALREADY_ARMED, "already armed")
    if need_flying and state.landed:
        return GoalProblem(GoalError.NOT_FLYING, "not flying (landed)")
    if need_landed and not state.landed:
        return GoalProblem(GoalError.ALREADY_FLYING, "already flying")
    if need_offboard and not state.offboard:
        return GoalProblem(GoalError.NOT_IN_CONTROL,
                           f"not in offboard control (FCU {nav_state_text(state.nav_state)})")
    return None


def check_takeoff_altitude(altitude: float, home_z: float, bounds: FieldBounds,
                           min_altitude: float) -> GoalProblem | None:
    """A takeoff ``altitude`` [m above the take-off point at ``home_z``]: the hover point
    must be at or above the floor and under the field's ceiling."""
    if not math.isfinite(altitude):
        return GoalProblem(GoalError.NOT_FINITE, f"altitude {altitude} is not finite")
    z = home_z + altitude
    if z < min_altitude:
        return GoalProblem(GoalError.BELOW_FLOOR,
                           f"takeoff altitude {fmt_m(altitude)} m ends at z = {fmt_m(z)} m, "
                           f"below the floor {fmt_m(min_altitude)} m")
    if z > bounds.upper[2]:
        return GoalProblem(GoalError.OUTSIDE_FIELD,
                           f"takeoff altitude {fmt_m(altitude)} m ends at z = {fmt_m(z)} m, "
                           f"above the field's ceiling {_fmt_bound(bounds.upper[2])} m")
    return None


def check_speed(speed: float, max_speed: float) -> GoalProblem | None:
    """A requested speed [m/s or rad/s]: finite, >= 0 (0 = default), at most ``max_speed``."""
    if not math.isfinite(speed) or speed < 0.0:
        return GoalProblem(GoalError.NOT_FINITE, f"speed {speed} must be finite and >= 0")
    if speed > max_speed:
        return GoalProblem(GoalError.TOO_FAST,
                           f"speed {fmt_m(speed)} is above the limit {fmt_m(max_speed)}")
    return None


__all__ = [
    "NO_POSITION_MESSAGE",
    "FieldBounds",
    "GoalError",
    "GoalProblem",
    "VehicleState",
    "battery_critical",
    "check_speed",
    "check_takeoff_altitude",
    "check_target",
    "check_vehicle",
    "fmt_m",
]
