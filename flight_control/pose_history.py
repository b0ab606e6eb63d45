"""A bounded history of vehicle poses: "where was the vehicle at time t?".

The precision lander needs the pose at an image's capture time, not the latest one;
this keeps the last ``span_ns`` of odometry samples and interpolates between the two
around the asked time (linear in position and velocity, slerp in orientation). Pure
numpy; times are integer nanoseconds on the companion clock.
"""

from __future__ import annotations

import bisect
from collections import deque
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from flight_control.frames import quat_normalise

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class PoseSample:
    """One pose: time [ns], position [m], orientation (w, x, y, z), velocity [m/s]."""

    t_ns: int
    position: FloatArray
    q: FloatArray
    velocity: FloatArray


def slerp(q0: FloatArray, q1: FloatArray, u: float) -> FloatArray:
    """Spherical interpolation between unit quaternions (w, x, y, z), shortest arc."""
    dot = float(np.dot(q0, q1))
    if dot < 0.0:
        q1, dot = -q1, -dot
    if dot > 0.9995:  # nearly parallel: linear is exact enough and stable
        return np.asarray(quat_normalise(q0 + u * (q1 - q0)), dtype=np.float64)
    theta = np.arccos(dot)
    s = np.sin(theta)
    return (np.sin((1.0 - u) * theta) / s) * q0 + (np.sin(u * theta) / s) * q1


class PoseHistory:
    """The last ``span_ns`` of poses, in time order."""

    def __init__(self, span_ns: int) -> None:
        if span_ns <= 0:
            raise ValueError(f"span_ns: {span_ns} must be > 0")
        self.span_ns = span_ns
        self._samples: deque[PoseSample] = deque()
        self._times: deque[int] = deque()

    def __len__(self) -> int:
        return len(self._samples)

    def add(self, sample: PoseSample) -> None:
        """Append a sample; one older than the newest is ignored (odometry is ordered)."""
        if self._times and sample.t_ns <= self._times[-1]:
            return
        self._samples.append(sample)
        self._times.append(sample.t_ns)
        while self._times and self._times[0] < sample.t_ns - self.span_ns:
            self._samples.popleft()
            self._times.popleft()

    @property
    def span(self) -> tuple[int, int] | None:
        """Oldest and newest kept times [ns], None when empty."""
        return (self._times[0], self._times[-1]) if self._times else None

    def missing(self, t_ns: int) -> str:
        """Why :meth:`at` has no pose for ``t_ns``, in words."""
        span = self.span
        if span is None:
            return "no odometry kept yet"
        return (f"{t_ns / 1e9:.3f} s is outside the kept history "
                f"[{span[0] / 1e9:.3f}, {span[1] / 1e9:.3f}] s")

    def at(self, t_ns: int) -> PoseSample | None:
        """The pose at ``t_ns``, interpolated; None outside the kept span."""
        if not self._times or not self._times[0] <= t_ns <= self._times[-1]:
            return None
        i = bisect.bisect_left(self._times, t_ns)
        after = self._samples[i]
        if after.t_ns == t_ns or i == 0:
            return after
        before = self._samples[i - 1]
        u = (t_ns - before.t_ns) / (after.t_ns - before.t_ns)
        return PoseSample(
            t_ns,
            before.position + u * (after.position - before.position),
            slerp(before.q, after.q, u),
            before.velocity + u * (after.velocity - before.velocity),
        )
