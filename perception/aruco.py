"""ArUco recognition on the downward camera (seed 003 sec. 3.3.1, eq. 1-2). Pure: numpy
and OpenCV, no runtime.

Pipeline (:class:`ArucoScanner`): grey image -> optional preprocessing passes (tried in
order until every wanted marker is found; which passes, and in which order, was chosen by
measurement: ``benchmarks/bench_aruco_table1.py``) -> ``cv2.aruco.ArucoDetector``
(DICT_7X7_1000, sub-pixel corners) -> an ID whitelist per :class:`ScanMode` -> for each
marker the centre by eq. 1, the image-centre error, eq. 2 into the body frame, and the
metric offset and height from the pinhole model and the marker's known size
(``solvePnP`` with ``SOLVEPNP_IPPE_SQUARE``).

Frames:

- image: pixel ``(u, v)``, u to the right, v down, origin at the top-left pixel's centre.
  The down camera is mounted with image up = body forward and image right = body right
  (as in seed 003), looking straight down;
- camera optical frame (OpenCV): x right, y down, z along the optical axis (down);
- body frame: **FLU** (x forward, y left, z up), REP 103. The seed writes eq. 2 in the
  NED body frame (FRD): ``e_x = -e_y^v, e_y = e_x^v``. In FLU the same rotation reads
  ``e_x = -e_y^v, e_y = -e_x^v`` (y left = -right); :func:`camera_to_body` implements
  the FLU form and :func:`camera_to_body_frd` the seed's, and a test checks they agree.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
Image = npt.NDArray[np.uint8]

DICTIONARY_NAME = "DICT_7X7_1000"
PAD_IDS = frozenset(range(1, 11))  # landing pads (seed 003)
ROBOT_IDS = frozenset(range(12, 27))  # ground robots (seed 003)


class ScanMode(Enum):
    """Which markers the scanner reports (seed 003: pads 1-10, robots 12-26)."""

    PADS = "pads"
    ROBOTS = "robots"
    BOTH = "both"

    def accepts(self, marker_id: int) -> bool:
        if self is ScanMode.PADS:
            return marker_id in PAD_IDS
        if self is ScanMode.ROBOTS:
            return marker_id in ROBOT_IDS
        return marker_id in PAD_IDS or marker_id in ROBOT_IDS


class MarkerKind(Enum):
    """What a marker is printed on."""

    PAD = "pad"
    ROBOT = "robot"
    OTHER = "other"

    @classmethod
    def of(cls, marker_id: int) -> MarkerKind:
        if marker_id in PAD_IDS:
            return cls.PAD
        if marker_id in ROBOT_IDS:
            return cls.ROBOT
        return cls.OTHER


class Preprocess(Enum):
    """A detection pass; :class:`ScannerSettings` lists them in order."""

    NONE = "none"  # the grey image as it is
    STRETCH = "stretch"  # contrast stretched (1st-99.5th percentile) and lightly blurred
    SMALL = "small"  # each small dark square decoded by correlation with the whitelisted IDs


@dataclass(frozen=True)
class ScannerSettings:
    """How the scanner detects. ``passes`` are tried in order until every wanted marker
    is found; the defaults are the measured choice (``benchmarks/bench_aruco_table1.py``:
    dark frames are dim, ~25 grey levels between black and white, below OpenCV's
    adaptive-threshold constant of 7 once blurred, so STRETCH; 3.5 cm markers at 1.2 m
    are 12 px, 1.3 px per module, too few for OpenCV to threshold into bits (upscaling
    each candidate and retrying 20 detector settings read 85 %), so SMALL samples each
    small dark square's module grid and correlates it with the whitelisted IDs, see
    :func:`decode_small`). ``opencv_defaults()`` is the seed's baseline."""

    passes: tuple[Preprocess, ...] = (Preprocess.NONE, Preprocess.STRETCH, Preprocess.SMALL)
    subpixel: bool = True  # CORNER_REFINE_SUBPIX
    adaptive_win_min: int = 3  # px, adaptive threshold windows (OpenCV: 3, 23, 10)
    adaptive_win_max: int = 53
    adaptive_win_step: int = 10
    threshold_constant: float = 7.0  # grey levels below the local mean (OpenCV: 7)
    min_perimeter_rate: float = 0.02  # of the image's larger side (OpenCV: 0.03)
    stretch_blur_px: float = 0.7  # Gaussian sigma after the stretch
    # STRETCH's adaptive windows [px]: its threshold constant of 3 on a stretched, noisy
    # frame makes many candidate contours, so it is the costly pass (~50 ms vs ~5 ms on an
    # empty frame with windows 3-53 px); 13-33 px (3 windows) instead of 3-53 (6) loses none
    # of the 103 markers NONE + STRETCH read on 390 frames over the arena, light and dark,
    # nor a Table 1 cell
    stretch_win_min: int = 13
    stretch_win_max: int = 33
    small_max_px: int = 40  # px, SMALL looks at dark squares up to this side
    small_max_candidates: int = 60  # per frame, nearest the image centre first
    # SMALL accepts a candidate when its sampled module grid correlates with a whitelisted
    # marker at least this well (Pearson, 11x11 modules: marker + quiet zone) and beats
    # every other whitelisted ID by the margin: on 600 rendered 12 px markers (light and
    # dark, tuning seeds 1-2) the true marker scored >= 0.87 with a margin >= 0.21 where
    # its candidate was found; other candidates at most 0.57 and a margin of 0.11
    small_min_correlation: float = 0.75
    small_min_margin: float = 0.15
    # A search whose smallest marker side (``min_side_px``) is at least this runs its passes
    # on the image halved (INTER_AREA: 4x fewer pixels, the noise averaged) and refines the
    # corners found on the full image (cornerSubPix): on 2,080 frames over random arenas'
    # pads and robots at 1.2-1.5 m, light and dark, the same 362 markers in each light as
    # at full resolution, the corners within 0.25 px (median <= 0.015 px), in 0.26-0.67x
    # the time (benchmarks/bench_scanner_overhead.py). 40 px takes in the robot search's
    # height, 1.9 m (floor 45.3 px): there, on 520 frames in each light, halved read 369
    # markers against 266 at full resolution in the light, 367 against 267 in the dark
    # (1 lost); from 2 m a robot is read ~1.0 m to the side of the lane halved in the
    # dark, 0.75-0.9 m at full resolution. 0: never halved
    half_res_min_side_px: float = 40.0

    def __post_init__(self) -> None:
        if not self.passes:
            raise ValueError("ScannerSettings.passes: give at least one pass")
        if self.adaptive_win_min < 3 or self.adaptive_win_max < self.adaptive_win_min:
            raise ValueError(
                f"ScannerSettings: adaptive windows [{self.adaptive_win_min}, "
                f"{self.adaptive_win_max}] px must satisfy 3 <= min <= max")
        if not 3 <= self.stretch_win_min <= self.stretch_win_max:
            raise ValueError(f"ScannerSettings: STRETCH windows [{self.stretch_win_min}, "
                             f"{self.stretch_win_max}] px must satisfy 3 <= min <= max")
        if self.adaptive_win_step < 1:
            raise ValueError(f"ScannerSettings.adaptive_win_step: {self.adaptive_win_step} < 1")
        if not 0.0 < self.min_perimeter_rate < 4.0:
            raise ValueError(
                f"ScannerSettings.min_perimeter_rate: {self.min_perimeter_rate} not in (0, 4)")
        if self.half_res_min_side_px < 0.0:
            raise ValueError(f"ScannerSettings.half_res_min_side_px: "
                             f"{self.half_res_min_side_px} < 0")
        if not -1.0 < self.small_min_correlation <= 1.0 or not 0.0 <= self.small_min_margin < 2.0:
            raise ValueError(
                f"ScannerSettings: small_min_correlation {self.small_min_correlation} not in "
                f"(-1, 1] or small_min_margin {self.small_min_margin} not in [0, 2)")

    @classmethod
    def opencv_defaults(cls) -> ScannerSettings:
        """OpenCV's ``DetectorParameters()`` as they come, one pass, no refinement: the
        seed's baseline."""
        return cls(passes=(Preprocess.NONE,), subpixel=False, adaptive_win_min=3,
                   adaptive_win_max=23, adaptive_win_step=10, min_perimeter_rate=0.03,
                   half_res_min_side_px=0.0)


@dataclass(frozen=True)
class Marker:
    """One detected marker, measured in the image, the camera and the body frame."""

    id: int
    kind: MarkerKind
    corners_px: FloatArray  # (4, 2), clockwise from the marker's top-left, as OpenCV gives
    center_px: FloatArray  # (2,), eq. 1
    error_px: FloatArray  # (2,), (e_x^v, e_y^v): centre minus the principal point, image axes
    position_cam: FloatArray  # (3,) m, marker centre in the camera optical frame (PnP)
    offset_body: FloatArray  # (2,) m, marker centre from the optical axis, body FLU x, y (eq. 2)
    height: float  # m, camera above the marker plane, along the optical axis
    rotation_cam: FloatArray = field(repr=False)  # (3, 3), marker -> camera optical frame
    reprojection_error_px: float = 0.0  # RMS over the four corners
    side_length: float = 0.0  # m, printed side used for the metric estimate


# --- eq. 1, eq. 2 ------------------------------------------------------------------------
def marker_center(corners: npt.ArrayLike) -> FloatArray:
    """Seed 003 eq. 1: the intersection of the diagonals (P1, P3) and (P2, P4).

    Under perspective this is the exact image of the square's centre (the corner mean is
    not). Raises ValueError for a degenerate quadrilateral (parallel diagonals)."""
    p = np.asarray(corners, dtype=np.float64).reshape(4, 2)
    (x1, y1), (x2, y2), (x3, y3), (x4, y4) = p
    den = (x1 - x3) * (y2 - y4) - (x2 - x4) * (y1 - y3)
    if abs(den) < 1e-12:
        raise ValueError(f"marker_center: the diagonals of {p.tolist()} are parallel")
    a = x1 * y3 - x3 * y1
    b = x4 * y2 - x2 * y4
    xc = ((x2 - x4) * a + (x1 - x3) * b) / den
    yc = ((y1 - y3) * b + (y2 - y4) * a) / den
    return np.array([xc, yc])


def image_error(center_px: npt.ArrayLike, cx: float, cy: float) -> FloatArray:
    """The centre expressed from the principal point: ``(e_x^v, e_y^v)`` [px], image axes."""
    c = np.asarray(center_px, dtype=np.float64)
    return np.array([c[0] - cx, c[1] - cy])


def camera_to_body(error_v: npt.ArrayLike) -> FloatArray:
    """Eq. 2 in the FLU body frame: ``(x forward, y left) = (-e_y^v, -e_x^v)``."""
    ev = np.asarray(error_v, dtype=np.float64)
    return np.array([-ev[1], -ev[0]])


def camera_to_body_frd(error_v: npt.ArrayLike) -> FloatArray:
    """Eq. 2 as the seed writes it (NED body, FRD): ``(e_x, e_y) = (-e_y^v, e_x^v)``."""
    ev = np.asarray(error_v, dtype=np.float64)
    return np.array([-ev[1], ev[0]])


def body_offset(center_px: npt.ArrayLike, height: float, camera: FloatArray) -> FloatArray:
    """The marker centre from the optical axis [m], body FLU (x, y): the eq. 1 centre,
    eq. 2, and the pinhole model at ``height`` [m] along the axis (``camera`` is K)."""
    fx, fy, cx, cy = camera[0, 0], camera[1, 1], camera[0, 2], camera[1, 2]
    ev = image_error(center_px, cx, cy)
    return camera_to_body(np.array([ev[0] * height / fx, ev[1] * height / fy]))


def optical_to_body(v_cam: npt.ArrayLike) -> FloatArray:
    """A vector from the down camera's optical frame into body FLU (image up = forward)."""
    v = np.asarray(v_cam, dtype=np.float64)
    return np.array([-v[1], -v[0], -v[2]])


# --- detection ---------------------------------------------------------------------------
@functools.cache
def _dictionary() -> cv2.aruco.Dictionary:
    return cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_7X7_1000)


def _detector(settings: ScannerSettings, constant: float | None = None,
              min_perimeter_rate: float | None = None,
              windows: tuple[int, int] | None = None) -> cv2.aruco.ArucoDetector:
    params = cv2.aruco.DetectorParameters()
    if settings != ScannerSettings.opencv_defaults():
        params.adaptiveThreshWinSizeMin = settings.adaptive_win_min
        params.adaptiveThreshWinSizeMax = settings.adaptive_win_max
        params.adaptiveThreshWinSizeStep = settings.adaptive_win_step
        params.adaptiveThreshConstant = settings.threshold_constant
        params.minMarkerPerimeterRate = settings.min_perimeter_rate
    if constant is not None:
        params.adaptiveThreshConstant = constant
    if min_perimeter_rate is not None:
        params.minMarkerPerimeterRate = min_perimeter_rate
    if windows is not None:
        params.adaptiveThreshWinSizeMin, params.adaptiveThreshWinSizeMax = windows
    if settings.subpixel:
        params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
    return cv2.aruco.ArucoDetector(_dictionary(), params)


STRETCH_PERCENTILES = (1.0, 99.5)  # the grey levels :func:`stretch` maps to 0 and 255


def grey_percentiles(grey: Image, percentiles: Sequence[float]) -> list[float]:
    """``np.percentile(grey, percentiles)`` (linear interpolation) of a uint8 image, read
    off its 256-bin histogram: the same values, without sorting 300 k pixels."""
    cumulative = np.cumsum(cv2.calcHist([grey], [0], None, [256], [0, 256]).ravel())
    n = int(cumulative[-1])
    out = []
    for q in percentiles:
        position = q / 100.0 * (n - 1)
        below = math.floor(position)
        # the k-th smallest pixel (0-based) is the first level whose count passes k
        lo, hi = np.searchsorted(cumulative, (below + 1, min(below + 2, n)), side="left")
        out.append(float(lo) + (position - below) * float(hi - lo))
    return out


def stretch(grey: Image, part: Image | None = None) -> Image:
    """Contrast stretch: the 1st percentile to 0, the 99.5th to 255 (a lookup table).
    ``part`` (a crop of ``grey``, or one halved) is stretched by ``grey``'s percentiles
    instead."""
    lo, hi = grey_percentiles(grey, STRETCH_PERCENTILES)
    scale = 255.0 / max(hi - lo, 1.0)
    levels = np.arange(256, dtype=np.float32)
    table = np.clip((levels - np.float32(lo)) * np.float32(scale), 0, 255).astype(np.uint8)
    return np.asarray(cv2.LUT(grey if part is None else part, table), dtype=np.uint8)


def to_grey(image: npt.ArrayLike) -> Image:
    """An (H, W) uint8 grey image of an RGB (H, W, 3) or grey uint8 image."""
    a = np.asarray(image)
    if a.dtype != np.uint8:
        raise ValueError(f"image: expected uint8, got {a.dtype}")
    if a.ndim == 3 and a.shape[2] == 3:
        return np.asarray(cv2.cvtColor(a, cv2.COLOR_RGB2GRAY), dtype=np.uint8)
    if a.ndim == 2:
        return a
    raise ValueError(f"image: expected (H, W) or (H, W, 3), got shape {a.shape}")


# --- SMALL: decoding markers of ~1-2 px per module by correlation ------------------------
_GRID_MODULES = 11  # the 9x9 marker (7x7 bits + black border) and its one-module quiet zone
# grey levels below the 21 px local mean (stretched image): 5 finds most squares; in the
# dark, noise can join a marker to its surroundings at 5 and 10 separates them
SMALL_THRESHOLD_CONSTANTS = (5, 10)
_UNIT_SQUARE = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=np.float32)


def _similarities() -> tuple[FloatArray, FloatArray]:
    """The small pose search around a candidate: shifts [px] x scales x turns [deg]."""
    mats, shifts = [], []
    for dx, dy, scale, turn in itertools.product((-0.6, 0.0, 0.6), (-0.6, 0.0, 0.6),
                                                 (0.92, 1.0, 1.08), (-6.0, 0.0, 6.0)):
        c, s = math.cos(math.radians(turn)), math.sin(math.radians(turn))
        mats.append(scale * np.array([[c, -s], [s, c]]))
        shifts.append((dx, dy))
    return np.asarray(mats, dtype=np.float64), np.asarray(shifts, dtype=np.float64)


_SIM_MATS, _SIM_SHIFTS = _similarities()


@functools.cache
def _pattern_bank(ids: tuple[int, ...]) -> FloatArray:
    """Each ID's 11x11 module grid (black 0, white 1, quiet zone white) in its four
    rotations, zero-mean and unit-variance: rows ``4 * k + r`` for ``ids[k]`` seen with
    the quad's corners rolled back by r."""
    rows = []
    for marker_id in ids:
        grid = np.ones((_GRID_MODULES, _GRID_MODULES))
        grid[1:-1, 1:-1] = _dictionary().generateImageMarker(marker_id, 9, borderBits=1) / 255.0
        for r in range(4):
            v = np.rot90(grid, r).ravel()
            rows.append((v - v.mean()) / v.std())
    return np.asarray(rows, dtype=np.float64)


@dataclass(frozen=True)
class SmallHit:
    """The best whitelisted ID for one candidate square (:func:`decode_small`)."""

    id: int
    correlation: float  # Pearson, sampled grid against the ID's pattern, best pose
    margin: float  # over the best other whitelisted ID
    corners_px: FloatArray  # (4, 2), OpenCV's order, of the best pose


def side_px(quad: npt.ArrayLike) -> float:
    """A quad's longest side [px] of its corners (4, 2)."""
    quad = np.asarray(quad, dtype=np.float64).reshape(4, 2)
    return float(np.max(np.linalg.norm(quad - np.roll(quad, 1, axis=0), axis=1)))


def small_candidates(grey: Image, max_px: float) -> list[FloatArray]:
    """Dark, nearly square blobs up to ``max_px`` on a side (adaptive threshold at each
    of :data:`SMALL_THRESHOLD_CONSTANTS`): each a quad (4, 2), its corners clockwise in
    the image, from the blob's minimum-area rectangle."""
    smooth = cv2.GaussianBlur(grey, (0, 0), 0.7)
    contours: list[Any] = []
    for constant in SMALL_THRESHOLD_CONSTANTS:
        dark = cv2.adaptiveThreshold(smooth, 255, cv2.ADAPTIVE_THRESH_MEAN_C,
                                     cv2.THRESH_BINARY_INV, 21, constant)
        contours += cv2.findContours(dark, cv2.RETR_LIST, cv2.CHAIN_APPROX_SIMPLE)[0]
    quads = []
    for contour in contours:
        if len(contour) < 4:
            continue
        rect = cv2.minAreaRect(contour)
        w, h = rect[1]
        if not 6.0 <= max(w, h) <= max_px or min(w, h) < 0.7 * max(w, h):
            continue
        if cv2.contourArea(contour) < 0.6 * w * h:
            continue
        box = np.asarray(cv2.boxPoints(rect), dtype=np.float64)
        d = box - box.mean(axis=0)
        quads.append(box[np.argsort(np.arctan2(d[:, 1], d[:, 0]))])
    return quads


def decode_small(image: npt.NDArray[np.float32], quad: npt.ArrayLike,
                 ids: tuple[int, ...]) -> SmallHit | None:
    """Which of ``ids`` the square ``quad`` (4, 2 px, clockwise) shows, for markers too
    small for OpenCV's bit thresholding: the 11x11 module centres (marker and quiet zone)
    are sampled bilinearly through the quad's homography, over a small pose search
    (+-0.6 px, +-8 % scale, +-6 deg) around it, and correlated with each ID's pattern in
    its four rotations. The best ID, its correlation and its margin over the others
    (None when ``ids`` is empty); the caller applies the acceptance thresholds."""
    if not ids:
        return None
    q = np.asarray(quad, dtype=np.float64).reshape(4, 2)
    homography = cv2.getPerspectiveTransform(_UNIT_SQUARE, q.astype(np.float32))
    g = (np.arange(_GRID_MODULES) - 0.5) / (_GRID_MODULES - 2)
    gx, gy = np.meshgrid(g, g)
    p = homography @ np.stack([gx.ravel(), gy.ravel(), np.ones(gx.size)])
    middle = q.mean(axis=0)
    points = (p[:2] / p[2]).T - middle
    poses = np.einsum("kij,nj->kni", _SIM_MATS, points) + middle + _SIM_SHIFTS[:, None, :]
    samples = cv2.remap(image, poses[..., 0].astype(np.float32),
                        poses[..., 1].astype(np.float32), cv2.INTER_LINEAR,
                        borderMode=cv2.BORDER_REPLICATE).astype(np.float64)
    samples -= samples.mean(axis=1, keepdims=True)
    samples /= samples.std(axis=1, keepdims=True) + 1e-9
    scores = samples @ _pattern_bank(ids).T / samples.shape[1]  # (poses, 4 * len(ids))
    best = scores.max(axis=0)
    j = int(np.argmax(best))
    k = int(np.argmax(scores[:, j]))
    per_id = best.reshape(len(ids), 4).max(axis=1)
    others = np.delete(per_id, j // 4)
    corners = (q - middle) @ _SIM_MATS[k].T + middle + _SIM_SHIFTS[k]
    return SmallHit(id=ids[j // 4], correlation=float(best[j]),
                    margin=float(best[j] - others.max()) if others.size else float(best[j]),
                    corners_px=np.roll(corners, j % 4, axis=0))


SUBPIX_WINDOW_PX = 5  # half-side of cornerSubPix's window, as the detector's refinement
SUBPIX_CRITERIA = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.01)


def _refined(grey: Image, found: dict[int, FloatArray]) -> dict[int, FloatArray]:
    """``found``'s corners [px of ``grey``] refined to sub-pixel on ``grey``."""
    if not found:
        return found
    ids = list(found)
    corners = np.concatenate([found[i] for i in ids]).astype(np.float32).reshape(-1, 1, 2)
    # a corner fitted outside the image (a marker cut by the frame's edge) has no pixels
    # to refine on, and cornerSubPix raises for it (an exception that would end the scan,
    # and with it the mission): it stays as found
    h, w = grey.shape[:2]
    xy = corners[:, 0, :]
    inside = (xy[:, 0] >= 0) & (xy[:, 0] < w) & (xy[:, 1] >= 0) & (xy[:, 1] < h)  # OpenCV's test
    if inside.any():  # each corner is refined on its own window: a subset refines the same
        some = corners[inside]
        cv2.cornerSubPix(grey, some, (SUBPIX_WINDOW_PX, SUBPIX_WINDOW_PX), (-1, -1),
                         SUBPIX_CRITERIA)
        corners[inside] = some
    refined = corners.reshape(-1, 4, 2).astype(np.float64)
    return {i: refined[k] for k, i in enumerate(ids)}


_MAX_DETECTORS = 256  # detectors kept by one scanner before the cache starts afresh
Region = tuple[int, int, int, int]
"""``(x0, y0, x1, y1)`` [px]: the pixels ``[y0:y1, x0:x1]`` of an image."""


class ArucoScanner:
    """Detects DICT_7X7_1000 markers and measures them (see the module docstring)."""

    def __init__(self, settings: ScannerSettings | None = None) -> None:
        self.settings = settings or ScannerSettings()
        # the detectors by (pass, crop's larger side, smallest perimeter [px]) seen lately
        self._detectors: dict[tuple[bool, int, int, bool], cv2.aruco.ArucoDetector] = {}
        self.searches = 0  # calls of find (for benchmarks and tests)
        self.searches_halved = 0  # of which ran on the image halved

    def _detector_for(self, stretched: bool, min_perimeter_px: float,
                      larger_side: int, halved: bool = False) -> cv2.aruco.ArucoDetector:
        """The NONE (or STRETCH) pass's detector for a crop whose larger side is
        ``larger_side`` [px], accepting perimeters from ``min_perimeter_px``: OpenCV
        takes that bound as a share of the image's larger side. On a ``halved`` image a
        corner may come half as near the border (OpenCV's 3 px would be 6 of the full
        image's)."""
        key = (stretched, larger_side, round(min_perimeter_px), halved)
        detector = self._detectors.get(key)
        if detector is None:
            if len(self._detectors) >= _MAX_DETECTORS:  # regions come in many sizes
                self._detectors.clear()
            rate = min(min_perimeter_px / larger_side, 3.9)
            s = self.settings
            detector = self._detectors[key] = (
                _detector(s, constant=3.0, min_perimeter_rate=rate,
                          windows=(s.stretch_win_min, s.stretch_win_max))
                if stretched else _detector(s, min_perimeter_rate=rate))
            if halved:
                params = detector.getDetectorParameters()
                params.minDistanceToBorder = max(1, params.minDistanceToBorder // 2)
                detector.setDetectorParameters(params)
        return detector

    @staticmethod
    def _collect(found: dict[int, FloatArray], mode: ScanMode, corners: Any, ids: Any) -> None:
        if ids is None:
            return
        for marker_id, c in zip(ids.ravel(), corners, strict=True):
            mid = int(marker_id)
            if mode.accepts(mid) and mid not in found:
                found[mid] = np.asarray(c, dtype=np.float64).reshape(4, 2)

    def _small_pass(self, grey: Image, rejected: Sequence[Any], mode: ScanMode,
                    found: dict[int, FloatArray], want: set[int] | None) -> None:
        s = self.settings
        ids = sorted(want if want is not None else
                     (i for i in PAD_IDS | ROBOT_IDS if mode.accepts(i)))
        ids = [i for i in ids if mode.accepts(i) and i not in found]
        if not ids:
            return
        quads = [np.asarray(q, dtype=np.float64).reshape(4, 2) for q in rejected]
        quads = [q for q in quads if side_px(q) <= s.small_max_px]
        quads += small_candidates(grey, s.small_max_px)
        h, w = grey.shape
        centre = np.array([(w - 1) / 2.0, (h - 1) / 2.0])
        quads.sort(key=lambda q: float(np.linalg.norm(q.mean(axis=0) - centre)))
        image = grey.astype(np.float32)
        for quad in quads[: s.small_max_candidates]:
            hit = decode_small(image, quad, tuple(ids))
            if hit is None or hit.correlation < s.small_min_correlation \
                    or hit.margin < s.small_min_margin or hit.id in found:
                continue
            found[hit.id] = hit.corners_px
            if want is not None and want <= found.keys():
                return

    def find(self, image: npt.ArrayLike, mode: ScanMode = ScanMode.BOTH,
             wanted: Iterable[int] | None = None, *, region: Region | None = None,
             min_side_px: float = 0.0) -> dict[int, FloatArray]:
        """``{id: corners (4, 2) px}`` of the accepted markers in ``image``.

        Passes run in order; the search stops once every ``wanted`` ID is found (any
        accepted marker when ``wanted`` is None). ``region`` limits the search to those
        pixels (corners stay in the whole image's pixels; the contrast stretch is the
        whole image's). ``min_side_px`` ignores outlines shorter than four such sides
        (OpenCV's ``minMarkerPerimeterRate`` of the whole image is the floor): a marker
        of known printed size seen from a known range is never smaller, and the noise's
        small outlines are what the detector spends its time on. From
        ``settings.half_res_min_side_px`` on, the passes run on the region halved and the
        corners are refined on the full image (see :class:`ScannerSettings`)."""
        grey = to_grey(image)
        height, width = grey.shape
        x0, y0, x1, y1 = (0, 0, width, height) if region is None else region
        if not (0 <= x0 < x1 <= width and 0 <= y0 < y1 <= height):
            raise ValueError(f"region {region} is not inside the {width}x{height} image")
        s = self.settings
        min_perimeter = max(s.min_perimeter_rate * max(width, height), 4.0 * min_side_px)
        crop = grey[y0:y1, x0:x1]
        halved = 0.0 < s.half_res_min_side_px <= min_side_px and min(crop.shape) >= 2
        work = crop
        self.searches += 1
        self.searches_halved += halved
        if halved:  # an even crop, each 2x2 block one pixel (centre 2i + 0.5 of the crop's)
            h2, w2 = crop.shape[0] // 2, crop.shape[1] // 2
            work = np.asarray(cv2.resize(crop[: 2 * h2, : 2 * w2], (w2, h2),
                                         interpolation=cv2.INTER_AREA), dtype=np.uint8)
            min_perimeter /= 2.0
        larger = max(work.shape)
        want = None if wanted is None else set(wanted)
        found: dict[int, FloatArray] = {}
        rejected: list[Any] = []
        stretched: Image | None = None
        for how in s.passes:
            if how is Preprocess.NONE:
                detector = self._detector_for(False, min_perimeter, larger, halved)
                corners, ids, rej = detector.detectMarkers(work)
                self._collect(found, mode, corners, ids)
                rejected.extend(rej)
            elif how is Preprocess.SMALL and min_side_px > s.small_max_px:
                continue  # it looks for squares smaller than any marker searched for
            else:
                if stretched is None:
                    stretched = stretch(grey, work)
                if how is Preprocess.STRETCH:
                    smooth = cv2.GaussianBlur(stretched, (0, 0), s.stretch_blur_px)
                    detector = self._detector_for(True, min_perimeter, larger, halved)
                    corners, ids, rej = detector.detectMarkers(smooth)
                    self._collect(found, mode, corners, ids)
                    rejected = list(rej) + rejected
                else:
                    self._small_pass(stretched, rejected, mode, found, want)
            if found and (want is None or want <= found.keys()):
                break
        if halved and found:
            found = _refined(crop, {i: 2.0 * c + 0.5 for i, c in found.items()})
        offset = np.array([x0, y0], dtype=np.float64)
        return {i: c + offset for i, c in found.items()}

    def detect(self, image: npt.ArrayLike, camera: npt.ArrayLike,
               side_lengths: dict[MarkerKind, float], mode: ScanMode = ScanMode.BOTH,
               wanted: Iterable[int] | None = None) -> list[Marker]:
        """Every accepted marker, measured (``camera`` is the 3x3 K, no distortion;
        ``side_lengths`` the printed side [m] of each kind). Sorted by ID."""
        return measure_all(self.find(image, mode, wanted), camera, side_lengths)


def measure_all(found: dict[int, FloatArray], camera: npt.ArrayLike,
                side_lengths: dict[MarkerKind, float]) -> list[Marker]:
    """:func:`measure` of each ``{id: corners}`` whose kind has a printed side in
    ``side_lengths`` [m] (``camera`` the 3x3 K), sorted by ID."""
    k = np.asarray(camera, dtype=np.float64).reshape(3, 3)
    markers = []
    for marker_id, corners in sorted(found.items()):
        side = side_lengths.get(MarkerKind.of(marker_id))
        if side is None or side <= 0.0:
            continue
        markers.append(measure(marker_id, corners, k, side))
    return markers


def _square_points(side: float) -> FloatArray:
    h = side / 2.0
    # OpenCV's marker corner order: top-left, top-right, bottom-right, bottom-left
    return np.array([[-h, h, 0.0], [h, h, 0.0], [h, -h, 0.0], [-h, -h, 0.0]])


def measure(marker_id: int, corners_px: npt.ArrayLike, camera: FloatArray,
            side: float) -> Marker:
    """Centre (eq. 1), image error, body offset (eq. 2 + pinhole) and height of one
    marker of printed side ``side`` [m] seen with camera matrix ``camera``."""
    corners = np.asarray(corners_px, dtype=np.float64).reshape(4, 2)
    obj = _square_points(side)
    ok, rvec, tvec = cv2.solvePnP(obj, corners, camera, None, flags=cv2.SOLVEPNP_IPPE_SQUARE)
    if not ok:
        raise ValueError(f"marker {marker_id}: solvePnP found no pose for {corners.tolist()}")
    projected, _ = cv2.projectPoints(obj, rvec, tvec, camera, None)
    reproj = float(np.sqrt(np.mean(np.sum((projected.reshape(4, 2) - corners) ** 2, axis=1))))
    t = np.asarray(tvec, dtype=np.float64).reshape(3)
    rotation, _ = cv2.Rodrigues(rvec)
    center = marker_center(corners)
    height = float(t[2])
    return Marker(
        id=marker_id,
        kind=MarkerKind.of(marker_id),
        corners_px=corners,
        center_px=center,
        error_px=image_error(center, camera[0, 2], camera[1, 2]),
        position_cam=t,
        offset_body=body_offset(center, height, camera),
        height=height,
        rotation_cam=np.asarray(rotation, dtype=np.float64),
        reprojection_error_px=reproj,
        side_length=side,
    )


def marker_yaw_in_body(marker: Marker) -> float:
    """The marker's +y axis (its 'up' edge) as a heading in the body frame [rad, FLU]."""
    up_body = optical_to_body(marker.rotation_cam[:, 1])
    return math.atan2(up_body[1], up_body[0])


def annotate(image: npt.ArrayLike, markers: Sequence[Marker]) -> Image:
    """An RGB copy of ``image`` with each marker's outline, ID, centre and height."""
    a = np.asarray(image, dtype=np.uint8)
    out = cv2.cvtColor(a, cv2.COLOR_GRAY2RGB) if a.ndim == 2 else a.copy()
    h, w = out.shape[:2]
    cv2.drawMarker(out, (w // 2, h // 2), (255, 255, 0), cv2.MARKER_CROSS, 16, 1)
    for m in markers:
        pts = np.round(m.corners_px).astype(np.int32).reshape(-1, 1, 2)
        colour = (0, 255, 0) if m.kind is MarkerKind.PAD else (255, 64, 0)
        cv2.polylines(out, [pts], True, colour, 2)
        c = (round(float(m.center_px[0])), round(float(m.center_px[1])))
        cv2.drawMarker(out, c, colour, cv2.MARKER_TILTED_CROSS, 12, 2)
        cv2.putText(out, f"{m.kind.value} {m.id} h={m.height:.2f}m", (c[0] + 8, c[1] - 8),
                    cv2.FONT_HERSHEY_SIMPLEX, 0.5, colour, 1, cv2.LINE_AA)
    return np.asarray(out, dtype=np.uint8)


__all__ = [
    "DICTIONARY_NAME",
    "PAD_IDS",
    "ROBOT_IDS",
    "ArucoScanner",
    "Marker",
    "MarkerKind",
    "Preprocess",
    "Region",
    "ScanMode",
    "ScannerSettings",
    "SmallHit",
    "annotate",
    "body_offset",
    "camera_to_body",
    "camera_to_body_frd",
    "decode_small",
    "grey_percentiles",
    "image_error",
    "marker_center",
    "marker_yaw_in_body",
    "measure",
    "measure_all",
    "optical_to_body",
    "side_px",
    "small_candidates",
    "stretch",
    "to_grey",
]
