"""The navigator node's explore path choice and its health, without flying (the flights are
in tests/quadmission/scenarios/test_navigate.py)."""

from __future__ import annotations

from typing import Any

import numpy as np

from navigation.coverage import lane_spacing
from navigation.navigator_node import NavigatorNode
from runtime import DeterministicExecutor, Node, qos_profile_default

FIELD = {"field_min": [0.0, 0.0, 0.0], "field_max": [20.0, 14.0, 4.0]}


def navigator(**overrides: Any) -> tuple[DeterministicExecutor, NavigatorNode]:
    ex = DeterministicExecutor()
    node = NavigatorNode(context=ex.context, parameter_overrides=FIELD | overrides)
    ex.add_node(node)
    return ex, node


def test_the_default_arena_flies_its_predefined_path() -> None:
    _, nav = navigator(arena="contest", start_pad=1)
    points, source = nav.explore_waypoints(np.empty((0, 2)), 1.5)
    assert "contest pad 1" in source
    assert np.allclose(points[:, :2], nav.explore_paths["contest"][1])
    assert np.all(points[:, 2] == 1.5)


def test_an_arena_without_a_path_gets_coverage_lanes_inside_the_walls() -> None:
    _, nav = navigator(arena="random-7", start_pad=4)
    points, source = nav.explore_waypoints(np.empty((0, 2)), 1.5)
    assert source == "coverage lanes over the field"
    margin = nav.params.wall_margin
    assert points[:, 0].min() >= margin - 1e-9 and points[:, 0].max() <= 20.0 - margin + 1e-9
    assert points[:, 1].min() >= margin - 1e-9 and points[:, 1].max() <= 14.0 - margin + 1e-9
    spacing = lane_spacing(1.5, nav.params.down_camera_fovy_deg, nav.params.down_camera_aspect,
                           nav.params.lane_overlap)
    lanes = np.unique(np.round(points[:, 1], 6))
    assert np.max(np.diff(lanes)) <= spacing + 1e-9


def test_an_explore_area_overrides_the_predefined_path() -> None:
    _, nav = navigator(arena="contest", start_pad=1)
    area = np.array([[2.0, 2.0], [8.0, 2.0], [8.0, 6.0], [2.0, 6.0]])
    points, source = nav.explore_waypoints(area, 2.0)
    assert source == "coverage lanes over the area"
    assert points[:, :2].min(axis=0).tolist() == [2.0, 2.0]
    assert points[:, :2].max(axis=0).tolist() == [8.0, 6.0]


def test_after_a_predefined_path_the_lane_sweeps_run_along_then_across() -> None:
    _, nav = navigator(arena="contest", start_pad=1)
    _, source = nav.explore_waypoints(np.empty((0, 2)), 1.5, sweep=0)
    assert source.startswith("explore path of contest")
    along, source = nav.explore_waypoints(np.empty((0, 2)), 1.5, sweep=1)
    assert source == "coverage lanes over the field"
    assert np.allclose(np.diff(along[:, 1])[::2], 0.0)  # lanes along x, the long side
    across, source = nav.explore_waypoints(np.empty((0, 2)), 1.5, sweep=2)
    assert source == "coverage lanes across the field"
    assert np.allclose(np.diff(across[:, 0])[::2], 0.0)  # lanes along y, the short side
    assert len(along) < len(across)  # the lanes along have fewer ends: the quicker cover


def test_without_a_predefined_path_the_first_sweep_is_lanes_along_then_across() -> None:
    _, nav = navigator(arena="random-7", start_pad=4)
    _, source = nav.explore_waypoints(np.empty((0, 2)), 1.5, sweep=0)
    assert source == "coverage lanes over the field"
    _, source = nav.explore_waypoints(np.empty((0, 2)), 1.5, sweep=1)
    assert source == "coverage lanes across the field"


class HealthListener(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("listener", **kwargs)
        self.reports: list[Any] = []
        self.create_subscription("quadmission_interfaces/msg/HealthReport",
                                 "/navigator/health", self.reports.append, qos_profile_default)


def test_health_says_what_is_missing() -> None:
    ex, _ = navigator()
    listener = HealthListener(context=ex.context)
    ex.add_node(listener)
    ex.spin_for(1.1)
    (report,) = listener.reports
    assert report.level == 1 and report.modules[0].name == "navigator"
    assert "odometry" in report.modules[0].message
