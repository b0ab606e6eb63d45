"""The app's facts for the nodes, and its checks that the nodes' configs agree on the
mission's heights."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from fsm.params import MissionParams
from navigation.navigator_node import NavigatorNode
from navigation.params import NavigatorParams
from navigation.voxel_graph import top_cube_centre
from perception.aruco import ScanMode, ScannerSettings
from perception.params import ScannerParams
from quadmission.assembly.companion import (
    check_mission_altitudes,
    check_turn_first_angle,
    horizontal_half_fov,
    navigator_overrides,
)
from runtime import DeterministicExecutor
from runtime.errors import ParameterError
from runtime.parameters import load_parameters
from sim.arena import default_arena
from sim.quadrotor import QuadrotorParams, onboard_cameras
from sim.render import CameraIntrinsics


def test_the_top_cube_is_the_highest_centre_under_the_ceiling() -> None:
    assert top_cube_centre(0.2, 2.0) == pytest.approx(1.9)
    assert top_cube_centre(0.2, 2.09) == pytest.approx(1.9)
    assert top_cube_centre(0.2, 2.1) == pytest.approx(2.1)
    assert top_cube_centre(0.25, 2.0) == pytest.approx(1.875)


def test_the_shipped_heights_are_planned_at_and_one_above_the_top_cube_is_refused() -> None:
    mission = load_parameters(MissionParams, "mission")
    check_mission_altitudes(default_arena(), mission)  # config/*.yaml agree
    with pytest.raises(ParameterError,
                       match=r"mission\.explore_altitude: 2\.0 m is outside .*-1\.9 m"):
        check_mission_altitudes(default_arena(), replace(mission, explore_altitude=2.0))
    with pytest.raises(ParameterError, match=r"mission\.cruise_altitude: 2\.3 m"):
        check_mission_altitudes(default_arena(), replace(mission, cruise_altitude=2.3))


def test_the_robot_search_is_scanned_on_the_halved_image() -> None:
    """At the explore altitude the scanner's floor stays at or above the halving threshold:
    searched at full resolution there, a mission cost 10 % more CPU (docs/speed.md)."""
    mission = load_parameters(MissionParams, "mission")
    scanner = load_parameters(ScannerParams, "aruco_scanner")
    fy = CameraIntrinsics.from_camera(QuadrotorParams().down_camera).fy
    floor = scanner.min_side_px(ScanMode.BOTH, fy,
                                mission.explore_altitude + scanner.height_margin_m)
    assert floor >= ScannerSettings().half_res_min_side_px


def test_the_navigator_knows_the_arena_from_the_app() -> None:
    arena = default_arena()
    node = NavigatorNode(context=DeterministicExecutor().context,
                         parameter_overrides=navigator_overrides(arena))
    assert (node.params.arena, node.params.start_pad) == (arena.name, arena.start_pad)
    assert np.allclose(node.field_max, arena.field.size)
    node.destroy_node()


def test_a_leg_flown_without_turning_first_stays_inside_the_depth_camera_s_view() -> None:
    """config/*.yaml agree (28.6 deg against the depth camera's 36.5 deg half field of view);
    45 deg, the old default under which random arena 208 hit a box face never seen, is
    refused with both angles named."""
    navigator = load_parameters(NavigatorParams, "navigator")
    check_turn_first_angle(navigator)
    camera = onboard_cameras().depth_camera
    assert math.degrees(horizontal_half_fov(camera)) == pytest.approx(36.5, abs=0.1)
    with pytest.raises(ParameterError, match=r"turn_first_angle: 0.785 rad \(45.0 deg\).*36.5 deg"):
        check_turn_first_angle(replace(navigator, turn_first_angle=0.785))
    wide = replace(camera, width=320)  # a wider camera allows it
    check_turn_first_angle(replace(navigator, turn_first_angle=0.785), wide)
