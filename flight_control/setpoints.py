"""Setpoint generation for the flight-control layer (seed 003, sec. 3.3.2): pure numpy.

A reach is a straight segment from where the vehicle is to the target, discretised into
intermediate setpoints ``spacing`` apart that are reached in sequence; a setpoint counts
as reached when the vehicle is inside a sphere of parameterised radius around it (the
seed's rule). Between them a carrot moves along the segment at cruise speed (trapezoidal
speed: accelerate, cruise, brake onto the target when stopping there), with its velocity
as feed-forward, so the vehicle flies at a known speed instead of at whatever speed the
FCU's position loop picks for a step. The carrot never passes the next intermediate
setpoint the vehicle has not reached: if the vehicle falls behind by more than the
sphere's radius, the carrot waits there, and the reach degrades to the seed's plain
setpoint sequence.

Frames: ENU map frame, metres, seconds, radians (ENU yaw: 0 = east, CCW positive).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from flight_control.frames import wrap_pi

FloatArray = npt.NDArray[np.float64]


def _vec3(value: npt.ArrayLike, name: str) -> FloatArray:
    v = np.asarray(value, dtype=np.float64).reshape(-1)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{name}: expected 3 finite numbers, got {value!r}")
    return v


def _positive(value: float, name: str) -> float:
    if not (math.isfinite(value) and value > 0.0):
        raise ValueError(f"{name}: {value!r} must be a finite number > 0")
    return float(value)


def interpolate_segment(start: npt.ArrayLike, target: npt.ArrayLike,
                        spacing: float) -> FloatArray:
    """Intermediate setpoints from ``start`` (excluded) to ``target`` (included, last).

    They are equally spaced along the straight segment, no more than ``spacing`` [m]
    apart: ``ceil(length / spacing)`` points, shape (N, 3), N >= 1 (a zero-length segment
    gives the target alone).
    """
    a, b = _vec3(start, "start"), _vec3(target, "target")
    spacing = _positive(spacing, "spacing")
    length = float(np.linalg.norm(b - a))
    n = max(1, math.ceil(length / spacing - 1e-9))
    fractions = np.arange(1, n + 1, dtype=np.float64) / n
    points: FloatArray = a + fractions[:, None] * (b - a)
    points[-1] = b  # exactly the target, whatever the rounding
    return points


def inside_sphere(position: npt.ArrayLike, center: npt.ArrayLike, radius: float) -> bool:
    """Whether ``position`` is inside (or on) the sphere of ``radius`` [m] around ``center``."""
    d = np.asarray(position, dtype=np.float64) - np.asarray(center, dtype=np.float64)
    return bool(float(np.linalg.norm(d)) <= radius)


def trapezoid_duration(length: float, speed: float, acceleration: float) -> float:
    """Seconds to cover ``length`` [m] from rest to rest, at most ``speed`` [m/s], with
    ``acceleration`` [m/s^2] to speed up and to brake."""
    speed, acceleration = _positive(speed, "speed"), _positive(acceleration, "acceleration")
    length = max(0.0, float(length))
    d_ramp = speed * speed / acceleration  # both ramps together
    if length <= d_ramp:
        return 2.0 * math.sqrt(length / acceleration)
    return 2.0 * speed / acceleration + (length - d_ramp) / speed


def yaw_toward(current: float, target: float, max_rate: float, dt: float) -> float:
    """``current`` [rad] turned toward ``target`` the short way, by at most
    ``max_rate * dt``; wrapped to (-pi, pi]."""
    step = _positive(max_rate, "max_rate") * max(0.0, dt)
    error = wrap_pi(target - current)
    if abs(error) <= step:
        return wrap_pi(target)
    return wrap_pi(current + math.copysign(step, error))


def yaw_between(start: float, target: float, fraction: float) -> float:
    """The heading ``fraction`` (clipped to [0, 1]) of the way from ``start`` to
    ``target`` [rad], turning the short way; wrapped to (-pi, pi]."""
    f = min(1.0, max(0.0, fraction))
    return wrap_pi(start + f * wrap_pi(target - start))


@dataclass(frozen=True)
class Carrot:
    """What to command now: position [m], velocity feed-forward [m/s], yaw [rad]."""

    position: FloatArray
    velocity: FloatArray
    yaw: float


@dataclass(frozen=True)
class ReachProgress:
    """Where a reach is: the carrot's arc length and speed, the next setpoint to reach."""

    s: float = 0.0  # m, carrot along the segment from the start
    speed: float = 0.0  # m/s, carrot speed
    next_index: int = 0  # the first intermediate setpoint not reached yet


@dataclass(frozen=True)
class ReachPlan:
    """A straight reach, discretised; build it with :meth:`build`."""

    start: FloatArray  # m, ENU
    target: FloatArray  # m, ENU
    points: FloatArray  # (N, 3) intermediate setpoints, the last one is the target
    cruise_speed: float  # m/s
    acceleration: float  # m/s^2
    waypoint_radius: float  # m, the sphere in which an intermediate setpoint is reached
    stop_at_target: bool = True
    start_yaw: float = 0.0  # rad
    target_yaw: float = 0.0  # rad
    arcs: FloatArray = field(init=False)  # (N,) m, arc length of each point from start

    def __post_init__(self) -> None:
        arcs = np.linalg.norm(self.points - self.start, axis=1)
        object.__setattr__(self, "arcs", arcs)

    @classmethod
    def build(cls, start: npt.ArrayLike, target: npt.ArrayLike, *, spacing: float,
              cruise_speed: float, acceleration: float, waypoint_radius: float,
              stop_at_target: bool = True, start_yaw: float = 0.0,
              target_yaw: float | None = None) -> ReachPlan:
        """The plan from ``start`` to ``target``; ``target_yaw`` None keeps ``start_yaw``."""
        a, b = _vec3(start, "start"), _vec3(target, "target")
        return cls(a, b, interpolate_segment(a, b, spacing),
                   _positive(cruise_speed, "cruise_speed"),
                   _positive(acceleration, "acceleration"),
                   _positive(waypoint_radius, "waypoint_radius"), stop_at_target,
                   wrap_pi(start_yaw), wrap_pi(start_yaw if target_yaw is None else target_yaw))

    @property
    def length(self) -> float:
        return float(self.arcs[-1])

    @property
    def direction(self) -> FloatArray:
        """Unit vector from start to target (zeros for a zero-length reach)."""
        d = self.target - self.start
        n = float(np.linalg.norm(d))
        return d / n if n > 0.0 else np.zeros(3)

    def expected_duration(self) -> float:
        """Seconds the carrot takes when it never waits for the vehicle."""
        return trapezoid_duration(self.length, self.cruise_speed, self.acceleration)

    def advance(self, progress: ReachProgress, position: npt.ArrayLike,
                dt: float) -> ReachProgress:
        """``progress`` after ``dt`` seconds with the vehicle at ``position``.

        First the sequence: each intermediate setpoint (not the target) whose sphere holds
        the vehicle is reached, in order. Then the carrot moves at most to the next
        unreached one, speeding up by ``acceleration``, capped by ``cruise_speed`` and, when
        stopping at the target, by the speed it can still brake from.
        """
        p = np.asarray(position, dtype=np.float64)
        last = len(self.points) - 1
        k = progress.next_index
        while k < last and inside_sphere(p, self.points[k], self.waypoint_radius):
            k += 1
        gate = float(self.arcs[k])
        speed = min(self.cruise_speed, progress.speed + self.acceleration * max(0.0, dt))
        if self.stop_at_target:
            speed = min(speed, math.sqrt(2.0 * self.acceleration
                                         * max(0.0, self.length - progress.s)))
        s = progress.s + speed * max(0.0, dt)
        if s >= gate:  # waiting at the next unreached setpoint, or at the target
            s = gate
            if k < last or self.stop_at_target:
                speed = 0.0
        return ReachProgress(s, speed, k)

    def carrot(self, progress: ReachProgress) -> Carrot:
        """The setpoint for ``progress``: on the segment, velocity along it."""
        u = self.direction
        fraction = progress.s / self.length if self.length > 0.0 else 1.0
        return Carrot(self.start + u * progress.s, u * progress.speed,
                      yaw_between(self.start_yaw, self.target_yaw, fraction))


__all__ = [
    "Carrot",
    "FloatArray",
    "ReachPlan",
    "ReachProgress",
    "inside_sphere",
    "interpolate_segment",
    "trapezoid_duration",
    "yaw_between",
    "yaw_toward",
]
