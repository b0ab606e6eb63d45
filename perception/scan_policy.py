"""The ArUco scanner's decisions, one image at a time (seed 003 sec. 3.3.1). Pure: numpy,
no runtime; the detection itself is :mod:`perception.aruco`'s.

:class:`ScanPolicy` decides, for ``aruco_scanner_node``:

- which images are scanned: while enabled, once the camera's intrinsics are known;
- how far the farthest marker can be: the vehicle's height above the map's floor (the
  odometry's z) plus a margin, while the odometry is fresh and finite; unknown otherwise
  (the node then falls back to ``max_range_m``);
- when an annotated image is due: at most ``annotated_rate_hz``, and only while someone
  listens;
- which robot markers are reported: each robot at most once per
  ``robot_report_interval_s``, its first sighting at once;
- where a robot is: each reported sighting puts the marker in the map frame from the
  vehicle's pose at capture time (:func:`marker_in_map`), and the robot's estimate is
  the running mean of them with its horizontal standard deviation (:class:`RobotTrack`);
- what health says: the camera stale or without intrinsics (while enabled), the counts.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from enum import Enum

import numpy as np
import numpy.typing as npt

from perception.aruco import MarkerKind, ScanMode, optical_to_body

FloatArray = npt.NDArray[np.float64]
Quaternion = tuple[float, float, float, float]  # w, x, y, z


class Problem(Enum):
    """What health reports as wrong with the scanner's inputs."""

    IMAGE_STALE = "image_stale"  # no image for image_timeout_s (or never)
    NO_CAMERA_INFO = "no_camera_info"  # no intrinsics yet: images cannot be measured


def rotate(q: Quaternion, v: npt.ArrayLike) -> FloatArray:
    """``v`` rotated by the unit quaternion ``q`` (w, x, y, z)."""
    w, x, y, z = q
    u = np.array([x, y, z])
    v = np.asarray(v, dtype=np.float64)
    return np.asarray(v + 2.0 * np.cross(u, np.cross(u, v) + w * v), dtype=np.float64)


def marker_in_map(vehicle_position: npt.ArrayLike, vehicle_orientation: Quaternion,
                  marker_position_cam: npt.ArrayLike, camera_position: npt.ArrayLike,
                  ) -> FloatArray:
    """The marker centre [m] in the map frame: its position in the down camera's optical
    frame, moved to the body (camera mounted at ``camera_position``, body FLU) and placed
    with the vehicle's pose."""
    in_body = optical_to_body(marker_position_cam) + np.asarray(camera_position)
    return np.asarray(vehicle_position, dtype=np.float64) + rotate(vehicle_orientation,
                                                                   in_body)


@dataclass
class RobotTrack:
    """One robot: its sightings merged (running mean and squared deviations, Welford) and
    when it was last reported."""

    sightings: int = 0
    mean: FloatArray | None = None  # m, map x, y, z
    sq: FloatArray | None = None  # running sum of squared deviations
    last_report_ns: int | None = None

    def add(self, position: FloatArray) -> None:
        """Merge one sighting at ``position`` [m, map]."""
        self.sightings += 1
        if self.mean is None or self.sq is None:
            self.mean, self.sq = position.copy(), np.zeros(3)
        else:
            delta = position - self.mean
            self.mean = self.mean + delta / self.sightings
            self.sq = self.sq + delta * (position - self.mean)

    @property
    def horizontal_std(self) -> float:
        """m, the sample standard deviation of the horizontal position; 0 from one."""
        n = self.sightings
        if n < 2 or self.sq is None:
            return 0.0
        return float(math.sqrt((self.sq[0] + self.sq[1]) / (n - 1)))


ODOMETRY_TIMEOUT_S = 0.1
"""s: an older height says too little of where the vehicle is now. The odometry comes at
100 Hz (this is ten lost in a row); the vehicle climbs at most 3 m/s (MPC_Z_VEL_MAX_UP),
0.3 m in this time, which ``height_margin_m`` covers: a climb since the odometry puts the
markers farther than its height says."""


#: s, allowed on top of ``image_timeout_s`` for the first image after the scanner is
#: switched on: it subscribes to the image topic again, and across processes the new
#: reader is matched (DDS discovery) before a frame can come
ENABLE_GRACE_S = 2.0


class ScanPolicy:
    """The scanner's state and decisions; see the module docstring. Times are int
    nanoseconds on the node's clock."""

    def __init__(self, *, enabled: bool, mode: ScanMode, annotated_rate_hz: float,
                 robot_report_interval_s: float, image_timeout_s: float,
                 height_margin_m: float = 0.0) -> None:
        self.enabled = enabled
        self.mode = mode
        self.annotated_rate_hz = annotated_rate_hz
        self.robot_report_interval_s = robot_report_interval_s
        self.image_timeout_s = image_timeout_s
        self.height_margin_m = height_margin_m
        self._height: tuple[int, float] | None = None  # (received ns, m)
        self.frames = 0  # images scanned
        self.frames_with_markers = 0
        self.detections = 0
        self.robots: dict[int, RobotTrack] = {}  # by marker ID, once reported
        self._last_image_ns: int | None = None
        self._enabled_ns: int | None = None  # when last switched on (None: on from the start)
        self._last_annotated_ns: int | None = None

    def enable(self, now_ns: int, on: bool) -> bool:
        """Switch scanning on or off; whether that changed anything. Switched on, the
        images are awaited from now: the first is stale only after ``image_timeout_s``
        plus :data:`ENABLE_GRACE_S`."""
        if on == self.enabled:
            return False
        self.enabled = on
        if on:
            self._enabled_ns = now_ns
        return True

    def set_mode(self, value: str) -> str | None:
        """Switch to the mode named ``value``; else say why not (and keep the mode)."""
        try:
            self.mode = ScanMode(value)
        except ValueError:
            allowed = ", ".join(m.value for m in ScanMode)
            return f"mode: {value!r} is not one of {allowed}"
        return None

    def height(self, now_ns: int, z: float) -> None:
        """The odometry says the vehicle is ``z`` [m] above the map's floor (NaN: not
        known)."""
        self._height = (now_ns, z) if math.isfinite(z) else None

    def marker_range_m(self, now_ns: int) -> float | None:
        """m, the farthest a marker on the floor (or on anything standing on it) can be
        from the camera: the fresh height plus ``height_margin_m``; None when the height
        is unknown or older than :data:`ODOMETRY_TIMEOUT_S`."""
        if self._height is None or now_ns - self._height[0] > ODOMETRY_TIMEOUT_S * 1e9:
            return None
        return max(self._height[1], 0.0) + self.height_margin_m

    def image(self, now_ns: int, camera_known: bool) -> bool:
        """An image arrived: whether to scan it."""
        self._last_image_ns = now_ns
        return self.enabled and camera_known

    def scanned(self, now_ns: int, markers: Sequence[tuple[int, MarkerKind]]) -> list[int]:
        """An image was scanned and these (ID, kind) markers accepted: the indices of the
        robot markers to report now (each then counts as reported at ``now_ns``)."""
        self.frames += 1
        self.frames_with_markers += bool(markers)
        self.detections += len(markers)
        due = []
        for i, (marker_id, kind) in enumerate(markers):
            if kind is MarkerKind.ROBOT and self._robot_due(marker_id, now_ns):
                self.robots.setdefault(marker_id, RobotTrack()).last_report_ns = now_ns
                due.append(i)
        return due

    def _robot_due(self, marker_id: int, now_ns: int) -> bool:
        track = self.robots.get(marker_id)
        if track is None or track.last_report_ns is None:
            return True
        return now_ns - track.last_report_ns >= self.robot_report_interval_s * 1e9

    def annotated_due(self, now_ns: int, listeners: int) -> bool:
        """Whether to publish an annotated image now (then it counts as published)."""
        rate = self.annotated_rate_hz
        if rate <= 0.0 or not listeners:
            return False
        last = self._last_annotated_ns
        if last is None or now_ns - last >= 1e9 / rate:
            self._last_annotated_ns = now_ns
            return True
        return False

    def sighting(self, marker_id: int, position: FloatArray) -> RobotTrack:
        """A reported robot marker placed at ``position`` [m, map]: its merged track."""
        track = self.robots.setdefault(marker_id, RobotTrack())
        track.add(position)
        return track

    def problems(self, now_ns: int, camera_known: bool) -> list[Problem]:
        """What is wrong with the inputs while enabled (nothing while disabled)."""
        if not self.enabled:
            return []
        last, on = self._last_image_ns, self._enabled_ns
        if on is not None and (last is None or last < on):  # none since switched on
            stale = now_ns - on > (self.image_timeout_s + ENABLE_GRACE_S) * 1e9
        else:
            stale = last is None or now_ns - last > self.image_timeout_s * 1e9
        return ([Problem.IMAGE_STALE] if stale else []) + \
            ([] if camera_known else [Problem.NO_CAMERA_INFO])


__all__ = [
    "ENABLE_GRACE_S",
    "ODOMETRY_TIMEOUT_S",
    "Problem",
    "Quaternion",
    "RobotTrack",
    "ScanPolicy",
    "marker_in_map",
    "rotate",
]
