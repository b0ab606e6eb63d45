"""Judging a flight against ground truth: the setpoints the flight-control layer streamed
(``/fcu/setpoint``, recorded as any subscriber would) against where the simulator says
the vehicle was at the same instants.

Evaluation only: the companion never sees any of this. Map frame (ENU), metres, seconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from runtime import Node, Time, qos_profile_sensor_data
from sim.world import Trajectory

FloatArray = npt.NDArray[np.float64]
SETPOINT_TOPIC = "/fcu/setpoint"


class SetpointRecorder(Node):
    """Keeps every ``/fcu/setpoint`` (stamp [s], position [m]) for evaluation."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("setpoint_recorder", **kwargs)
        self._rows: list[tuple[float, float, float, float]] = []
        self.create_subscription("quadmission_interfaces/msg/FcuSetpoint", SETPOINT_TOPIC,
                                 self._on_setpoint, qos_profile_sensor_data)

    def _on_setpoint(self, msg: Any) -> None:
        p = msg.position
        self._rows.append((Time.from_msg(msg.header.stamp).nanoseconds / 1e9, p.x, p.y, p.z))

    def samples(self) -> tuple[FloatArray, FloatArray]:
        """Stamps [s] (N,) and positions [m] (N, 3); NaN where an axis was not commanded."""
        rows = np.array(self._rows, dtype=np.float64).reshape(-1, 4)
        return rows[:, 0], rows[:, 1:4]


@dataclass(frozen=True)
class Tracking:
    """Setpoint vs flown position over a window: per-sample errors and their summary."""

    t: FloatArray  # s, setpoint stamps in the window
    setpoint: FloatArray  # m, (N, 3)
    flown: FloatArray  # m, (N, 3), ground truth at the stamps
    window: tuple[float, float]  # s

    @property
    def error(self) -> FloatArray:
        """Flown minus setpoint [m], (N, 3)."""
        return self.flown - self.setpoint

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
        """Largest 3-D distance [m] between setpoint and vehicle; None without samples."""
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
    return Tracking(t, setpoints[keep], flown, (start, end))


def rounded(value: float | None, digits: int = 4) -> float | None:
    """``value`` rounded for a report; None stays None, and so does a non-finite number."""
    if value is None or not math.isfinite(value):
        return None
    return round(float(value), digits)


__all__ = ["SETPOINT_TOPIC", "SetpointRecorder", "Tracking", "rounded", "tracking"]
