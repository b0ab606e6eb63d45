"""Exploration paths: predefined ones from YAML, or boustrophedon coverage lanes.

Pure (numpy, PyYAML). The seed predefines an exploration path per start pad, designed with
loop closures (the path comes back over ground it already mapped); we read those from
``config/explore_paths.yaml`` (arena name -> start pad -> [[x, y], ...]). Where there is none
(a random arena, another pad, an explore goal with its own area), :func:`coverage_lanes`
sweeps the area in lanes spaced by the down camera's footprint at the flight altitude, and
:class:`CoverageGrid` estimates the fraction of the area seen. Map frame (ENU), metres.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import numpy.typing as npt
import yaml

from navigation.errors import NavigationError

FloatArray = npt.NDArray[np.float64]


class ExplorePathsError(NavigationError, ValueError):
    """The explore paths file is malformed: the message names the key."""


def load_explore_paths(path: Path | str) -> dict[str, dict[int, FloatArray]]:
    """arena name -> start pad id -> (N, 2) waypoints [m]. A missing file is no paths."""
    path = Path(path)
    if not path.is_file():
        return {}
    doc = yaml.safe_load(path.read_text()) or {}
    root = doc.get("explore_paths", {}) if isinstance(doc, dict) else None
    if not isinstance(root, dict):
        raise ExplorePathsError(f"{path}: explore_paths must map arena names to pads")
    out: dict[str, dict[int, FloatArray]] = {}
    for arena, pads in root.items():
        if not isinstance(pads, dict):
            raise ExplorePathsError(f"{path}: explore_paths.{arena} must map pad ids to paths")
        out[str(arena)] = {}
        for pad, points in pads.items():
            arr = np.asarray(points, dtype=np.float64)
            if arr.ndim != 2 or arr.shape[1] != 2 or len(arr) == 0 or not np.all(np.isfinite(arr)):
                raise ExplorePathsError(
                    f"{path}: explore_paths.{arena}.{pad} must be a list of [x, y] points [m]")
            out[str(arena)][int(pad)] = arr
    return out


def footprint_half_size(altitude: float, fovy_deg: float, aspect: float) -> tuple[float, float]:
    """Half-width and half-height [m] of the down camera's view of the floor from
    ``altitude`` [m]: (along the image width, along the image height)."""
    half_h = max(altitude, 0.0) * math.tan(math.radians(fovy_deg) / 2.0)
    return half_h * aspect, half_h


def lane_spacing(altitude: float, fovy_deg: float, aspect: float, overlap: float) -> float:
    """Lane spacing [m]: the footprint's narrow side, less the overlap."""
    half_w, half_h = footprint_half_size(altitude, fovy_deg, aspect)
    return 2.0 * min(half_w, half_h) * (1.0 - overlap)


def coverage_lanes(lo: npt.ArrayLike, hi: npt.ArrayLike, spacing: float,
                   start: npt.ArrayLike | None = None, *, across: bool = False) -> FloatArray:
    """Boustrophedon waypoints (N, 2) over the rectangle [lo, hi]: lanes along the longer
    side (along the shorter one when ``across``), ``spacing`` apart (the first and last on
    the edges), starting from the corner nearest ``start``."""
    lo_a = np.asarray(lo, dtype=np.float64).reshape(2)
    hi_a = np.asarray(hi, dtype=np.float64).reshape(2)
    if not np.all(hi_a >= lo_a) or not spacing > 0.0:
        raise ValueError(f"coverage lanes: area {lo_a.tolist()}..{hi_a.tolist()} m, spacing "
                         f"{spacing} m")
    along = int((hi_a[0] - lo_a[0] >= hi_a[1] - lo_a[1]) == across)
    side = 1 - along
    width = hi_a[side] - lo_a[side]
    n = max(1, math.ceil(width / spacing - 1e-9) + 1)
    offsets = np.linspace(lo_a[side], hi_a[side], n) if n > 1 else np.array([lo_a[side]])
    points = []
    forward = True
    for c in offsets:
        ends = (lo_a[along], hi_a[along]) if forward else (hi_a[along], lo_a[along])
        for e in ends:
            p = np.empty(2)
            p[along], p[side] = e, c
            points.append(p)
        forward = not forward
    lanes = np.asarray(points)
    if start is not None:  # begin at the corner nearest the start
        s = np.asarray(start, dtype=np.float64).reshape(2)
        variants = []
        for flip_along in (False, True):
            for flip_across in (False, True):
                v = lanes.copy()
                if flip_along:
                    v[:, along] = lo_a[along] + hi_a[along] - v[:, along]
                if flip_across:
                    v[:, side] = lo_a[side] + hi_a[side] - v[:, side]
                variants += [v, v[::-1]]
        lanes = min(variants, key=lambda v: float(np.linalg.norm(v[0] - s)))
    return lanes


class CoverageGrid:
    """Cells of an area marked as seen by the down camera's footprint."""

    def __init__(self, lo: npt.ArrayLike, hi: npt.ArrayLike, cell: float) -> None:
        self.lo = np.asarray(lo, dtype=np.float64).reshape(2)
        self.hi = np.asarray(hi, dtype=np.float64).reshape(2)
        self.cell = float(cell)
        shape = np.maximum(np.ceil((self.hi - self.lo) / self.cell).astype(int), 1)
        self.seen = np.zeros((int(shape[0]), int(shape[1])), dtype=bool)
        idx = np.indices(self.seen.shape).reshape(2, -1).T
        self._centres = self.lo + (idx + 0.5) * self.cell

    def mark(self, xy: npt.ArrayLike, half_size: tuple[float, float], yaw: float) -> None:
        """Mark the cells whose centre is in the footprint rectangle at ``xy``, rotated by
        ``yaw`` (the image width along body y, the height along body x)."""
        half_w, half_h = half_size
        d = self._centres - np.asarray(xy, dtype=np.float64).reshape(2)
        c, s = math.cos(yaw), math.sin(yaw)
        fwd = d[:, 0] * c + d[:, 1] * s
        left = -d[:, 0] * s + d[:, 1] * c
        inside = (np.abs(fwd) <= half_h) & (np.abs(left) <= half_w)
        self.seen.reshape(-1)[inside] = True

    @property
    def fraction(self) -> float:
        return float(self.seen.mean())


__all__ = ["CoverageGrid", "ExplorePathsError", "coverage_lanes", "footprint_half_size",
           "lane_spacing", "load_explore_paths"]
