"""Exploration paths (navigation/coverage.py): YAML paths, coverage lanes, coverage."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from navigation.coverage import (
    CoverageGrid,
    ExplorePathsError,
    coverage_lanes,
    footprint_half_size,
    lane_spacing,
    load_explore_paths,
)
from runtime.parameters import config_path


def test_the_default_arena_has_a_looping_explore_path_from_pad_1() -> None:
    paths = load_explore_paths(config_path("explore_paths.yaml"))
    path = paths["contest"][1]
    assert path.shape[1] == 2 and len(path) > 5
    # loop closure: the path comes back within 0.5 m of an earlier, non-adjacent waypoint
    closes = [i for i in range(2, len(path)) if
              np.min(np.linalg.norm(path[: i - 1] - path[i], axis=1)) < 0.5]
    assert len(closes) >= 2


def test_bad_explore_paths_are_named(tmp_path) -> None:  # type: ignore[no-untyped-def]
    bad = tmp_path / "paths.yaml"
    bad.write_text("explore_paths:\n  contest:\n    1: [[1, 2, 3]]\n")
    with pytest.raises(ExplorePathsError, match=r"contest\.1"):
        load_explore_paths(bad)
    assert load_explore_paths(tmp_path / "none.yaml") == {}


def test_lane_spacing_follows_the_camera_footprint() -> None:
    half_w, half_h = footprint_half_size(1.5, 60.0, 4 / 3)
    assert half_h == pytest.approx(1.5 * math.tan(math.radians(30)))
    assert half_w == pytest.approx(half_h * 4 / 3)
    assert lane_spacing(1.5, 60.0, 4 / 3, 0.2) == pytest.approx(2 * half_h * 0.8)


def test_lanes_sweep_the_area_and_cover_it() -> None:
    lo, hi = np.array([1.0, 1.0]), np.array([19.0, 13.0])
    spacing = lane_spacing(1.5, 60.0, 4 / 3, 0.2)
    lanes = coverage_lanes(lo, hi, spacing, start=(18.0, 12.0))
    assert np.linalg.norm(lanes[0] - [19.0, 13.0]) < 1e-9  # from the nearest corner
    assert np.all(lanes >= lo - 1e-9) and np.all(lanes <= hi + 1e-9)
    ys = np.unique(np.round(lanes[:, 1], 6))
    assert np.max(np.diff(ys)) <= spacing + 1e-9  # lanes along x, no gap wider than spacing
    grid = CoverageGrid(lo, hi, 0.25)
    for a, b in itertools.pairwise(lanes):
        for t in np.linspace(0, 1, 60):
            grid.mark(a + t * (b - a), footprint_half_size(1.5, 60.0, 4 / 3), 0.0)
    assert grid.fraction > 0.99


def test_lanes_across_run_along_the_shorter_side() -> None:
    lo, hi = np.array([1.0, 1.0]), np.array([19.0, 13.0])
    lanes = coverage_lanes(lo, hi, 1.3, start=(1.0, 1.0), across=True)
    assert np.linalg.norm(lanes[0] - [1.0, 1.0]) < 1e-9
    legs = np.diff(lanes, axis=0)[::2]  # every other leg runs a lane
    assert np.allclose(legs[:, 0], 0.0) and np.allclose(np.abs(legs[:, 1]), 12.0)
    xs = np.unique(np.round(lanes[:, 0], 6))
    assert xs[0] == 1.0 and xs[-1] == 19.0 and np.max(np.diff(xs)) <= 1.3 + 1e-9


def test_coverage_grid_marks_the_rotated_footprint() -> None:
    grid = CoverageGrid((0, 0), (10, 10), 0.5)
    grid.mark((5.0, 5.0), (2.0, 0.5), 0.0)  # 4 m across (y), 1 m along (x)
    seen = np.argwhere(grid.seen)
    centres = (seen + 0.5) * 0.5
    assert np.ptp(centres[:, 1]) > np.ptp(centres[:, 0])
    rotated = CoverageGrid((0, 0), (10, 10), 0.5)
    rotated.mark((5.0, 5.0), (2.0, 0.5), math.pi / 2)
    c2 = (np.argwhere(rotated.seen) + 0.5) * 0.5
    assert np.ptp(c2[:, 0]) > np.ptp(c2[:, 1])
