"""Judging the mission against ground truth, and what the app gives the mission's nodes."""

from __future__ import annotations

import numpy as np
import pytest

from quadmission.errors import OptionsError
from quadmission.evaluation.mission import distance_m, landing, score, touchdown_summary
from quadmission.scenarios.mission.scenario import (
    flown_arena,
    pads_overrides,
    robots_overrides,
    target_robot,
)
from sim.arena import PAD_SIZE, default_arena
from sim.world import Trajectory


def still_at(x: float, y: float, t_end: float = 10.0) -> Trajectory:
    t = np.linspace(0.0, t_end, 11)
    position = np.tile([x, y, 0.05], (len(t), 1))
    return Trajectory(t, position, np.tile([1.0, 0, 0, 0], (len(t), 1)), np.zeros_like(position))


def test_a_touchdown_inside_the_pad_counts_and_one_beside_it_does_not() -> None:
    arena = default_arena()
    cx, cy = arena.pad(5).center
    on = landing(arena, 5, 3.0, still_at(cx + 0.3, cy - 0.4))
    assert on.inside and on.error_m == pytest.approx(0.5)
    off = landing(arena, 5, 3.0, still_at(cx + PAD_SIZE / 2 + 0.01, cy))
    assert not off.inside
    late = landing(arena, 5, 11.0, still_at(cx, cy))  # after the recording: unknown
    assert late.touchdown_xy is None and not late.inside
    table = {5: 30, 6: 25}
    assert score([on], table) == 30
    assert score([on, off], table) == 30  # a pad counts once, when landed inside
    assert score([off], table) == 0
    summary = touchdown_summary([on, off])
    assert not summary["all_inside"] and summary["touchdown_max_m"] == pytest.approx(0.51)


def test_the_distance_flown_is_the_path_length_in_the_window() -> None:
    t = np.array([0.0, 1.0, 2.0, 3.0])
    p = np.array([[0, 0, 0], [3, 4, 0], [3, 4, 2], [0, 0, 0]], dtype=float)
    truth = Trajectory(t, p, np.zeros((4, 4)), np.zeros((4, 3)))
    assert distance_m(truth, (0.0, 2.0)) == pytest.approx(7.0)
    assert distance_m(truth, (0.0, 3.0)) == pytest.approx(7.0 + np.hypot(5.0, 2.0))


def test_a_removed_pad_leaves_the_field_but_stays_on_the_published_map() -> None:
    published = default_arena()
    flown = flown_arena(published, 3)
    assert 3 not in flown.pad_ids and 3 in published.pad_ids
    assert all(3 not in r.points_table for r in flown.robots)
    assert 3 in pads_overrides(published)["pad_ids"]
    with pytest.raises(OptionsError, match="takes off from it"):
        flown_arena(published, published.start_pad)
    with pytest.raises(OptionsError, match="has pads"):
        flown_arena(published, 42)


def test_the_operator_gets_each_robots_row_in_pad_order_and_the_target_is_checked() -> None:
    arena = default_arena()
    rows = robots_overrides(arena)
    n = len(arena.pads)
    for i, robot in enumerate(arena.robots):
        assert rows["robot_points"][i * n:(i + 1) * n] == [robot.points_table[p.id]
                                                          for p in arena.pads]
    assert target_robot(arena, 14) == 14
    assert target_robot(arena, None) in rows["robot_ids"]
    with pytest.raises(OptionsError, match="has robots"):
        target_robot(arena, 12)
