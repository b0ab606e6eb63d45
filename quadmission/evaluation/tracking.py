"""Judging a flight against ground truth, where the simulator says the vehicle was, against
one of two references:

- :func:`tracking`: the setpoints the flight-control layer streamed (``/fcu/setpoint``,
  recorded as any subscriber would), at the setpoints' instants: how well the vehicle
  followed its commands;
- :func:`outline_tracking`: a planned path (a polyline at one altitude), at every ground
  truth sample: the distance to the nearest point of the path, so a flight whose commands
  cut a corner is penalised, which the setpoint comparison cannot see.

Evaluation only: the companion never sees any of this. Map frame (ENU), metres, seconds.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from interfaces import graph
from runtime import Node, Time
from sim.world import Trajectory

FloatArray = npt.NDArray[np.float64]


class SetpointRecorder(Node):
    """Keeps every ``/fcu/setpoint`` (stamp [s], position [m]) for evaluation."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("setpoint_recorder", **kwargs)
        self._rows: list[tuple[float, float, float, float]] = []
        setpoint = graph.FCU_SETPOINT
        self.create_subscription(setpoint.type, setpoint.name, self._on_setpoint,
                                 setpoint.subscriber_qos)

    def _on_setpoint(self, msg: Any) -> None:
        p = msg.position
        self._rows.append((Time.from_msg(msg.header.stamp).nanoseconds / 1e9, p.x, p.y, p.z))

    def samples(self) -> tuple[FloatArray, FloatArray]:
        """Stamps [s] (N,) and positions [m] (N, 3); NaN where an axis was not commanded."""
        rows = np.array(self._rows, dtype=np.float64).reshape(-1, 4)
        return rows[:, 0], rows[:, 1:4]


@dataclass(frozen=True)
class Tracking:
    """Flown position vs a reference over a window: per-sample errors and their summary."""

    t: FloatArray  # s, the sample instants in the window
    reference: FloatArray  # m, (N, 3), where the vehicle should have been at each
    flown: FloatArray  # m, (N, 3), ground truth at the same instants
    window: tuple[float, float]  # s
    against: str  # what the reference is, in words, for reports and plots

    @property
    def error(self) -> FloatArray:
        """Flown minus reference [m], (N, 3)."""
        return self.flown - self.reference

    @property
    def error_xy(self) -> FloatArray:
        return np.hypot(self.error[:, 0], self.error[:, 1])

    def rmse(self) -> dict[str, float | None]:
        """RMSE [m] per axis and in the plane; None without samples."""
        if len(self.t) == 0:
            return {"x": None, "y": None, "z": None, "xy": None}
        e = self.error
        per_axis: dict[str, float | None] = {
            axis: float(np.sqrt(np.mean(e[:, i] ** 2))) for i, axis in enumerate("xyz")}
        return per_axis | {"xy": float(np.sqrt(np.mean(self.error_xy ** 2)))}

    def max_error(self) -> float | None:
        """Largest 3-D distance [m] between reference and vehicle; None without samples."""
        return float(np.max(np.linalg.norm(self.error, axis=1))) if len(self.t) else None


def tracking(stamps: FloatArray, setpoints: FloatArray, truth: Trajectory,
             window: tuple[float, float]) -> Tracking:
    """The setpoints stamped in ``[start, end)`` of ``window`` [s], each paired with the
    true position interpolated at its stamp. Setpoints with an axis left free (NaN) and
    stamps outside the recorded truth are left out."""
    start, end = window
    keep = (stamps >= start) & (stamps < end) & np.all(np.isfinite(setpoints), axis=1)
    if len(truth):
        keep &= (stamps >= truth.t[0]) & (stamps <= truth.t[-1])
    else:
        keep &= False
    t = stamps[keep]
    flown = np.column_stack([np.interp(t, truth.t, truth.position[:, i]) for i in range(3)]) \
        if len(t) else np.zeros((0, 3))
    return Tracking(t, setpoints[keep], flown, (start, end), graph.FCU_SETPOINT.name)


def nearest_on_polyline(points: FloatArray, polyline: FloatArray) -> FloatArray:
    """For each point (N, 2), the nearest point (N, 2) of the polyline (M >= 1, 2): of its
    segments, or its one point. Points and polyline in the same frame and unit."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    vertices = np.asarray(polyline, dtype=np.float64).reshape(-1, 2)
    if len(vertices) == 0:
        raise ValueError("the polyline has no points")
    if len(vertices) == 1:
        return np.repeat(vertices, len(points), axis=0)
    a, b = vertices[:-1], vertices[1:]  # (S, 2) segments
    ab = b - a
    length_sq = np.einsum("sk,sk->s", ab, ab)
    ap = points[:, None, :] - a[None, :, :]  # (N, S, 2)
    along = np.einsum("nsk,sk->ns", ap, ab) / np.where(length_sq > 0.0, length_sq, 1.0)
    foot = a[None] + np.clip(along, 0.0, 1.0)[..., None] * ab[None]  # (N, S, 2)
    nearest = np.argmin(np.einsum("nsk,nsk->ns", points[:, None] - foot,
                                  points[:, None] - foot), axis=1)
    return foot[np.arange(len(points)), nearest]


def outline_tracking(truth: Trajectory, outline: Sequence[tuple[float, float]],
                     altitude: float, window: tuple[float, float]) -> Tracking:
    """Every ground-truth sample in ``[start, end)`` of ``window`` [s] against the planned
    path: the polyline ``outline`` [m] (closed if its last point is its first) flown at
    ``altitude`` [m]. The reference of a sample is the nearest point of the path, so the
    horizontal error is the distance to the outline, the vertical one the height off
    ``altitude``; where along the path the vehicle is (early, late) does not count."""
    start, end = window
    keep = (truth.t >= start) & (truth.t < end)
    t, flown = truth.t[keep], truth.position[keep].reshape(-1, 3)
    nearest = nearest_on_polyline(flown[:, :2], np.asarray(outline, dtype=np.float64))
    reference = np.column_stack([nearest, np.full(len(t), float(altitude))])
    return Tracking(t, reference, flown, (start, end), "the planned outline")


def rounded(value: float | None, digits: int = 4) -> float | None:
    """``value`` rounded for a report; None stays None, and so does a non-finite number."""
    if value is None or not math.isfinite(value):
        return None
    return round(float(value), digits)


__all__ = ["SetpointRecorder", "Tracking", "nearest_on_polyline",
           "outline_tracking", "rounded", "tracking"]
