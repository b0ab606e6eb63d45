"""Precision landing on an ArUco pad (seed 003 sec. 3.3.2, eq. 3 and the descent rules).
Pure: numpy only, no runtime.

The seed's algorithm, per marker measurement, in order:

1. attitude gate: roll and pitch near zero, else the measurement is discarded;
2. eq. 3: the body-frame error is rotated by the yaw into the map frame;
3. a first-order filter;
4. truncation to centimetres;
5. if the pad centre is inside ``align_radius`` and the vehicle slower than
   ``max_align_speed``: the reference altitude goes down by ``descent_step``, and below
   ``min_altitude`` the final landing is handed to the flight controller;
6. otherwise (and after a step down) a reach to the current position plus the error.

Frames: the seed works in NED (body FRD, world NED); we work in ENU map / FLU body
(REP 103). Eq. 3 is the same rotation in both (a rotation about the vertical by the yaw,
each frame's yaw measured from its own x axis), so :func:`body_to_map` is eq. 3 as
written, applied to FLU (x forward, y left) vectors with the ENU yaw.

On top of the seed, selectable (:class:`LandingStrategy`) so the two can be compared:

- ``CAPTURE``: the measurement is combined with the pose **at the image's capture time**
  (the node asks ``/fcu/pose_at``), so each frame gives a map-frame estimate of the pad
  centre that stays right while the vehicle moves; the filter runs on that estimate,
  and the error is taken from the latest position to it. ``SEED`` adds the error to the
  latest pose and filters the error itself, as the paper does;
- phases after PX4's precision landing: SEARCH (a square spiral around the pad's known
  position while the marker is not in view, with a timeout; the policy checks each leg on
  the map, :mod:`navigation.search_legs`, and may skip a point:
  :meth:`PrecisionLander.skip_search_point`), ALIGN, DESCEND, FINAL_LAND,
  and a retry count when the marker is lost during the descent (climb back, search);
- outlier rejection: a pad estimate that jumps more than ``outlier_distance`` from the
  filtered one, or a PnP height that disagrees with the vehicle's, is dropped (a flipped
  or misread marker);
- with the camera's latency in mind (the frame a decision reads was exposed
  ``latency`` before it is read), CAPTURE
  * levels each measurement with the roll and pitch **at capture**
    (:func:`level_offset`): the camera looks along the tilted body axis, so a tilt of
    0.03 rad at 1 m puts the pad 3 cm off; the seed only gates the tilt (a 0.06 rad gate
    lets 4-9 cm through at 0.8-1.5 m). The latest attitude would not do: hovering, roll
    and pitch change by about 0.02 rad from one frame to the next, as much as the tilt
    itself, so 50 ms of latency leave most of the error in;
  * averages the pad's (static) map position over the frames since it was found: a
    running mean whose gain falls as 1/n to ``pad_filter_gain``;
  * decides only on ``min_fresh_frames`` frames **exposed** after the last move ended
    (:meth:`PrecisionLander.move_ended`), not merely read after it;
  * hands the final landing over only when the pad is within ``land_radius`` of the
    vehicle by the filtered error itself (untruncated: truncation towards zero lets a
    4.2 cm error pass a 3 cm gate), else it corrects at the lowest step first: the
    flight controller's landing descends where the vehicle is.

:class:`PrecisionLander` is the whole decision as a step function: the node feeds it
each measurement (or "no marker in this frame") and carries out the command it returns.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]


class LandingStrategy(Enum):
    """Which precision landing runs (see the module docstring)."""

    SEED = "seed"  # seed 003 as written: latest pose, filter on the error, no phases
    CAPTURE = "capture"  # ours: pose at capture time, phases with search, outlier rejection


class Phase(Enum):
    """Where the landing is; values are PrecisionLand feedback's PHASE_* codes."""

    SEARCH = 0
    ALIGN = 1
    DESCEND = 2
    FINAL_LAND = 3


class Failure(Enum):
    """Why a landing gave up; the node maps each to a PrecisionLand result code."""

    NOT_FOUND = "marker not found"
    LOST = "marker lost during the descent"
    TIMEOUT = "timeout"


@dataclass(frozen=True)
class LandingParams:
    """The algorithm's constants (units in the comments). The node reads them from
    ``config/precision_land.yaml`` (``precision_land_node.PrecisionLandParams``)."""

    max_tilt: float = 0.06  # rad, attitude gate on roll and pitch
    filter_gain: float = 0.5  # first-order filter: y += gain * (x - y), (0, 1]
    resolution: float = 0.01  # m, errors truncated to this (seed: centimetres)
    align_radius: float = 0.04  # m, the pad centre must be this close to descend
    max_align_speed: float = 0.1  # m/s, and the vehicle this slow
    descent_step: float = 0.3  # m, the reference altitude goes down by this
    min_altitude: float = 0.8  # m above the pad: below it, the final landing
    search_altitude: float = 1.5  # m above the pad, while searching
    search_spacing: float = 0.8  # m between the legs of the search spiral
    search_rings: int = 2  # squares of the spiral around the pad's position
    search_detour: float = 2.0  # m, a search point reached only by a longer way round is skipped
    search_timeout_s: float = 30.0  # s without seeing the marker in SEARCH
    lost_timeout_s: float = 2.0  # s without the marker while aligning or descending
    retries: int = 2  # searches after a loss (CAPTURE)
    timeout_s: float = 120.0  # s, the whole landing
    outlier_distance: float = 0.25  # m, a pad estimate this far from the filtered one is dropped
    height_tolerance: float = 0.3  # m, PnP height vs the vehicle's height above the pad
    max_rejections: int = 6  # consecutive drops before the filter restarts from the data
    min_fresh_frames: int = 2  # frames exposed after a move before deciding (CAPTURE)
    pad_filter_gain: float = 0.5  # CAPTURE: floor of the pad average's gain 1/n, (0, 1]
    land_radius: float = 0.04  # m, CAPTURE: the final landing only this close (untruncated)

    def __post_init__(self) -> None:
        checks = {
            "max_tilt": 0.0 < self.max_tilt < math.pi / 2,
            "filter_gain": 0.0 < self.filter_gain <= 1.0,
            "resolution": 0.0 <= self.resolution < 1.0,
            "align_radius": self.align_radius > 0.0,
            "max_align_speed": self.max_align_speed > 0.0,
            "descent_step": self.descent_step > 0.0,
            "min_altitude": self.min_altitude > 0.0,
            "search_altitude": self.search_altitude >= self.min_altitude,
            "search_spacing": self.search_spacing > 0.0,
            "search_rings": self.search_rings >= 0,
            "search_detour": self.search_detour >= 0.0,
            "search_timeout_s": self.search_timeout_s > 0.0,
            "lost_timeout_s": self.lost_timeout_s > 0.0,
            "retries": self.retries >= 0,
            "timeout_s": self.timeout_s > 0.0,
            "outlier_distance": self.outlier_distance > 0.0,
            "height_tolerance": self.height_tolerance > 0.0,
            "max_rejections": self.max_rejections >= 1,
            "min_fresh_frames": self.min_fresh_frames >= 1,
            "pad_filter_gain": 0.0 < self.pad_filter_gain <= 1.0,
            "land_radius": self.land_radius > 0.0,
        }
        bad = [k for k, ok in checks.items() if not ok]
        if bad:
            raise ValueError(f"LandingParams: out of range: {', '.join(bad)} "
                             f"(search_altitude must be >= min_altitude)")


# --- the seed's steps, one function each -----------------------------------------------
def attitude_ok(roll: float, pitch: float, max_tilt: float) -> bool:
    """The attitude gate: both angles [rad] within ``max_tilt``."""
    return abs(roll) <= max_tilt and abs(pitch) <= max_tilt


def level_offset(offset_body: npt.ArrayLike, height: float, roll: float, pitch: float,
                 ) -> FloatArray:
    """The camera's measurement levelled by the attitude at its exposure (CAPTURE).

    ``offset_body`` (FLU x, y) [m] and ``height`` [m] along the optical axis are the pad
    centre in the body frame as the camera saw it, ``(x, y, -height)`` (the down camera
    looks along body -z). Rotated by pitch then roll (the ZYX attitude without its yaw:
    ``R_y(pitch) R_x(roll)``), its x, y are the pad's horizontal offset in the level frame
    that eq. 3 then turns by the yaw. Level, it is ``offset_body`` itself."""
    x, y = np.asarray(offset_body, dtype=np.float64).reshape(2)
    z = -height
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    y1, z1 = cr * y - sr * z, sr * y + cr * z  # R_x(roll)
    return np.array([cp * x + sp * z1, y1])  # R_y(pitch), x and y


def body_to_map(error_body: npt.ArrayLike, yaw: float) -> FloatArray:
    """Eq. 3: ``[e_x^w, e_y^w] = R(yaw) [e_x, e_y]`` (FLU body -> ENU map, ENU yaw)."""
    e = np.asarray(error_body, dtype=np.float64).reshape(2)
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([c * e[0] - s * e[1], s * e[0] + c * e[1]])


def low_pass(previous: FloatArray | None, value: npt.ArrayLike, gain: float) -> FloatArray:
    """The first-order filter ``y += gain * (x - y)``; the first value passes as it is."""
    x = np.asarray(value, dtype=np.float64)
    if previous is None:
        return x.copy()
    return np.asarray(previous + gain * (x - previous), dtype=np.float64)


def truncate(value: npt.ArrayLike, resolution: float) -> FloatArray:
    """Truncate towards zero to a multiple of ``resolution`` [m] (seed: to centimetres)."""
    v = np.asarray(value, dtype=np.float64)
    if resolution <= 0.0:
        return v.copy()
    # the small epsilon keeps 0.07 (stored as 0.069999...) at 0.07
    return np.asarray(np.trunc(v / resolution + np.sign(v) * 1e-9) * resolution,
                      dtype=np.float64)


def aligned(error_map: npt.ArrayLike, speed: float, params: LandingParams) -> bool:
    """The descent condition: pad centre inside ``align_radius`` and slow enough."""
    return bool(np.hypot(*np.asarray(error_map, dtype=np.float64)) < params.align_radius
                and speed < params.max_align_speed)


def search_pattern(center: npt.ArrayLike, spacing: float, rings: int) -> list[FloatArray]:
    """A square spiral of (x, y) points around ``center``: the centre, then each ring's
    corners and edge midpoints, ``spacing`` [m] apart, anticlockwise."""
    c = np.asarray(center, dtype=np.float64).reshape(2)
    points = [c.copy()]
    for ring in range(1, rings + 1):
        r = ring * spacing
        for x, y in ((r, 0.0), (r, r), (0.0, r), (-r, r), (-r, 0.0), (-r, -r), (0.0, -r),
                     (r, -r)):
            points.append(c + np.array([x, y]))
    return points


# --- inputs and commands -----------------------------------------------------------------
@dataclass(frozen=True)
class Measurement:
    """The pad marker in one image: body-frame offset (FLU x, y) [m] of the pad centre
    from the camera's axis, and the camera's height above the marker [m]."""

    offset_body: tuple[float, float]
    height: float


@dataclass(frozen=True)
class Pose:
    """The vehicle: map position [m], yaw, roll, pitch [rad]."""

    position: tuple[float, float, float]
    yaw: float
    roll: float = 0.0
    pitch: float = 0.0


@dataclass(frozen=True)
class ReachTo:
    """Fly to this map position [m] and stop."""

    position: tuple[float, float, float]


@dataclass(frozen=True)
class LandNow:
    """Hand the final landing to the flight controller."""


@dataclass(frozen=True)
class Wait:
    """Nothing to do for this frame."""

    why: str = ""


@dataclass(frozen=True)
class Fail:
    failure: Failure
    message: str


Command = ReachTo | LandNow | Wait | Fail


@dataclass
class PrecisionLander:
    """The landing as a step function (see the module docstring).

    The node calls :meth:`on_frame` for each image the scanner looked at (``marker`` None
    when the pad's marker was not in it), with the pose that goes with the measurement
    (at capture time for CAPTURE, the latest for SEED), the latest position and speed,
    and whether a flight command is still running (then only the filter is updated).
    """

    params: LandingParams
    pad_position: tuple[float, float, float]  # m, map frame, where the pad should be
    strategy: LandingStrategy
    start_s: float
    phase: Phase = Phase.SEARCH
    reference_altitude: float = 0.0  # m above the pad
    filtered: FloatArray | None = None  # SEED: the error; CAPTURE: the pad centre (map xy)
    error: FloatArray | None = None  # m, map frame, last truncated error
    retries_left: int = 0
    rejected: int = 0  # consecutive outliers
    fresh_frames: int = 0  # frames exposed since the last command finished
    estimates: int = 0  # CAPTURE: pad estimates in the running mean since it (re)started
    _move_ended_s: float = -math.inf  # frames exposed before this say nothing new (CAPTURE)
    _last_seen_s: float | None = None
    _search_started_s: float = 0.0
    _search_points: list[FloatArray] = field(default_factory=list)
    _search_index: int = 0

    def __post_init__(self) -> None:
        self.retries_left = self.params.retries if self.capture else 0
        self._search_started_s = self.start_s

    @property
    def capture(self) -> bool:
        return self.strategy is LandingStrategy.CAPTURE

    def start(self, position: tuple[float, float, float]) -> None:
        """Begin at the vehicle's ``position`` [m]: the reference altitude is its height
        above the pad, at least ``min_altitude``."""
        self.reference_altitude = max(position[2] - self.pad_position[2],
                                      self.params.min_altitude)

    def move_ended(self, now_s: float) -> None:
        """The last move ended at ``now_s``: only frames exposed from then on count as
        fresh (a frame read after the end may have been exposed before it)."""
        self._move_ended_s = now_s

    def _height_ok(self, m: Measurement, pose: Pose) -> bool:
        expected = pose.position[2] - self.pad_position[2]
        return abs(m.height - expected) <= self.params.height_tolerance

    def _target(self, position: tuple[float, float, float], error: FloatArray,
                ) -> tuple[float, float, float]:
        return (position[0] + float(error[0]), position[1] + float(error[1]),
                self.pad_position[2] + self.reference_altitude)

    def _search_step(self, now_s: float, busy: bool) -> Command:
        p = self.params
        if now_s - self._search_started_s > p.search_timeout_s:
            return Fail(Failure.NOT_FOUND, f"no marker within {p.search_timeout_s:g} s of "
                                           "searching")
        if busy:
            return Wait("searching")
        if not self._search_points:
            rings = p.search_rings if self.capture else 0
            self._search_points = search_pattern(self.pad_position[:2], p.search_spacing, rings)
            self._search_index = 0
        if self._search_index >= len(self._search_points):
            if self.capture:
                self._search_index = 0  # go round again until the timeout
            else:
                return Wait("at the pad's position, waiting for the marker")
        x, y = self._search_points[self._search_index]
        self._search_index += 1
        self.reference_altitude = max(self.reference_altitude, p.search_altitude)
        return ReachTo((float(x), float(y), self.pad_position[2] + self.reference_altitude))

    def skip_search_point(self, now_s: float) -> Command:
        """The search point just returned will not be flown to (the map says it is not
        clear): the search's next command, as if that point had been reached."""
        return self._search_step(now_s, busy=False)

    def _lost(self, now_s: float, busy: bool) -> Command:
        p = self.params
        if self.retries_left > 0:
            self.retries_left -= 1
            self.phase = Phase.SEARCH
            self.filtered = None
            self.estimates = 0
            self._search_points = []
            self._search_started_s = now_s
            self._last_seen_s = None
            return self._search_step(now_s, busy)
        return Fail(Failure.LOST, f"no marker for {p.lost_timeout_s:g} s at "
                                  f"{self.reference_altitude:.2f} m above the pad")

    def on_frame(self, now_s: float, marker: Measurement | None, pose: Pose,
                 position: tuple[float, float, float], speed: float, busy: bool,
                 captured_s: float | None = None) -> Command:
        """One image looked at. ``pose``: the vehicle's pose for ``marker``; ``position``,
        ``speed``: the latest [m, m/s]; ``busy``: a reach is still being flown;
        ``captured_s``: the image's exposure (None: ``now_s``, no latency)."""
        p = self.params
        if now_s - self.start_s > p.timeout_s:
            return Fail(Failure.TIMEOUT, f"not landed after {p.timeout_s:g} s")
        exposed_s = now_s if captured_s is None else captured_s
        if not busy and (not self.capture or exposed_s >= self._move_ended_s):
            self.fresh_frames += 1
        if marker is None:
            if self.phase is Phase.SEARCH:
                if self._last_seen_s is None and now_s - self.start_s < p.lost_timeout_s \
                        and not self._search_points:
                    return Wait("looking for the marker where we are")
                return self._search_step(now_s, busy)
            last = self._last_seen_s if self._last_seen_s is not None else now_s
            if now_s - last > p.lost_timeout_s:
                return self._lost(now_s, busy)
            return Wait("marker not in this frame")

        # 1. attitude gate
        if not attitude_ok(pose.roll, pose.pitch, p.max_tilt):
            return Wait("attitude gate: not level")
        # 2. eq. 3 (CAPTURE: levelled first with the attitude at capture)
        offset = (level_offset(marker.offset_body, marker.height, pose.roll, pose.pitch)
                  if self.capture else marker.offset_body)
        error_w = body_to_map(offset, pose.yaw)
        # 3. filter (with outlier rejection for CAPTURE)
        if self.capture:
            pad = np.array([pose.position[0], pose.position[1]]) + error_w
            if not self._height_ok(marker, pose) or (
                    self.filtered is not None
                    and np.hypot(*(pad - self.filtered)) > p.outlier_distance):
                self.rejected += 1
                if self.rejected < p.max_rejections:
                    return Wait("outlier dropped")
                self.filtered = None  # the data disagree with us for long: trust the data
                self.estimates = 0
            self.rejected = 0
            self.estimates += 1  # the pad is still: a running mean, then a slow filter
            self.filtered = low_pass(self.filtered, pad,
                                     max(p.pad_filter_gain, 1.0 / self.estimates))
            raw_error = self.filtered - np.array([position[0], position[1]])
        else:
            self.filtered = low_pass(self.filtered, error_w, p.filter_gain)
            raw_error = self.filtered
        self._last_seen_s = now_s
        # 4. truncation
        self.error = truncate(raw_error, p.resolution)
        if self.phase is Phase.SEARCH:
            self.phase = Phase.ALIGN
            self._search_points = []
        if busy or (self.capture and self.fresh_frames < p.min_fresh_frames):
            return Wait("a move is being flown")
        self.fresh_frames = 0
        # 5. radius + velocity -> step down, land at the bottom
        if aligned(self.error, speed, p):
            if self.reference_altitude - p.descent_step < p.min_altitude:
                if not self.capture or float(np.hypot(*raw_error)) < p.land_radius:
                    self.reference_altitude -= p.descent_step
                    self.phase = Phase.FINAL_LAND
                    return LandNow()
                # CAPTURE: the landing descends where the vehicle is: centre it first
            else:
                self.reference_altitude -= p.descent_step
                self.phase = Phase.DESCEND
        # 6. reach the current position plus the error
        if self.capture:
            self._move_ended_s = max(self._move_ended_s, exposed_s)  # until move_ended
        return ReachTo(self._target(position, self.error))


__all__ = [
    "Command",
    "Fail",
    "Failure",
    "LandNow",
    "LandingParams",
    "LandingStrategy",
    "Measurement",
    "Phase",
    "Pose",
    "PrecisionLander",
    "ReachTo",
    "Wait",
    "aligned",
    "attitude_ok",
    "body_to_map",
    "level_offset",
    "low_pass",
    "search_pattern",
    "truncate",
]
