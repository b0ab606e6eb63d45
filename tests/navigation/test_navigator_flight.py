"""The navigator flying through the real flight-control node on the scripted FCU (no
MuJoCo): navigate around a wall on the path finder's graph, explore lanes, stop on a
marker. The map is a cloud published on /map/points, as the mapping node publishes it."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

import interfaces
from navigation.cloud_msgs import cloud_msg
from navigation.navigator_node import EXPLORE, NAVIGATE, NavigatorNode
from navigation.path_finder_node import PathFinderNode
from runtime import ActionClient, Node, Time, qos_profile_default, qos_profile_sensor_data
from tests.flight_control import rig as rig_module
from tests.flight_control.rig import FIELD, Rig, make_rig
from tests.flight_control.scripted_fcu import ScriptedFcu

# a wall at x = 5 m from y = 0 to 5 m, full height: the way round is north of y = 5
WALL = np.array([(5.05, y, z) for y in np.arange(0.05, 5.0, 0.1)
                 for z in np.arange(0.05, 4.0, 0.1)])
NAV_OVERRIDES = FIELD | {"survey_turns": 0, "turn_first_angle": 3.15, "cruise_altitude": 1.5,
                         "replace_blocked_lane_ends": True}


class Mission(Node):
    """The test's client of the navigator (not the mission node, which has parameters)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("navigator_client", **kwargs)
        self.map_pub = self.create_publisher("sensor_msgs/msg/PointCloud2", "/map/points",
                                             qos_profile_default)
        self.markers = self.create_publisher("quadmission_interfaces/msg/MarkerDetectionArray",
                                             "/perception/markers", qos_profile_default)
        self.navigate = ActionClient(self, NAVIGATE, "/navigation/navigate")
        self.explore = ActionClient(self, EXPLORE, "/navigation/explore")
        self.path: list[np.ndarray] = []
        self.create_subscription("nav_msgs/msg/Odometry", "/fcu/odometry", self._on_odom,
                                 qos_profile_sensor_data)

    def _on_odom(self, msg: Any) -> None:
        p = msg.pose.pose.position
        self.path.append(np.array([p.x, p.y, p.z]))

    def see_marker(self, marker_id: int) -> None:
        det = interfaces.new("quadmission_interfaces/msg/MarkerDetection", id=marker_id,
                             dictionary="DICT_7X7_1000")
        self.markers.publish(interfaces.new(
            "quadmission_interfaces/msg/MarkerDetectionArray",
            header=interfaces.new("std_msgs/msg/Header", stamp=self.now().to_msg()),
            detections=[det]))


@pytest.fixture
def stack() -> tuple[Rig, Mission]:
    rig = make_rig(flying_at=(1.0, 1.0, 1.5))
    ctx = rig.ex.context
    finder = PathFinderNode(context=ctx, parameter_overrides=FIELD)
    nav = NavigatorNode(context=ctx, parameter_overrides=NAV_OVERRIDES)
    mission = Mission(context=ctx)
    for node in (finder, nav, mission):
        rig.ex.add_node(node)
    mission.map_pub.publish(cloud_msg(WALL, Time(0).to_msg(), "map"))
    rig.ex.spin_for(0.5)
    return rig, mission


def run_goal(rig: Rig, client: ActionClient, goal: Any, limit_s: float,
             during: Any = None) -> Any:
    handle = rig.wait(client.send_goal_async(goal), 2.0)
    assert handle.accepted
    result = handle.get_result_async()
    t_end = rig.t() + limit_s
    while not result.done() and rig.t() < t_end:
        rig.ex.spin_for(0.5)
        if during is not None:
            during()
    assert result.done(), f"no result after {limit_s} s"
    return result.result().result


def test_navigate_goes_round_the_wall(stack) -> None:  # type: ignore[no-untyped-def]
    rig, mission = stack
    goal = interfaces.new(NAVIGATE.Goal, goal=interfaces.new(
        "geometry_msgs/msg/Point", x=8.0, y=1.0, z=1.5), yaw=math.nan)
    r = run_goal(rig, mission.navigate, goal, 60.0)
    assert r.success and r.result == NAVIGATE.Result.RESULT_OK, r.message
    assert math.dist((r.position.x, r.position.y, r.position.z), (8.0, 1.0, 1.5)) < 0.3
    flown = np.array(mission.path)
    crossing = flown[np.abs(flown[:, 0] - 5.05) < 0.6]  # beside the wall's x
    assert len(crossing) and crossing[:, 1].min() > 5.0 + 0.35  # round its end, not through


def test_navigate_to_a_goal_in_the_wall_says_no_path(stack) -> None:  # type: ignore[no-untyped-def]
    rig, mission = stack
    goal = interfaces.new(NAVIGATE.Goal, goal=interfaces.new(
        "geometry_msgs/msg/Point", x=5.05, y=2.0, z=1.5), yaw=math.nan)
    r = run_goal(rig, mission.navigate, goal, 30.0)
    assert not r.success and r.result == NAVIGATE.Result.RESULT_NO_PATH
    assert "GoalOccupied" in r.message


def area(x0: float, y0: float, x1: float, y1: float) -> list[Any]:
    return [interfaces.new("geometry_msgs/msg/Point", x=x, y=y, z=0.0)
            for x, y in ((x0, y0), (x1, y0), (x1, y1), (x0, y1))]


def test_explore_covers_an_area_with_lanes(stack) -> None:  # type: ignore[no-untyped-def]
    rig, mission = stack
    goal = interfaces.new(EXPLORE.Goal, area=area(1.0, 1.0, 4.0, 4.0), altitude=1.5)
    r = run_goal(rig, mission.explore, goal, 120.0)
    assert r.success and r.result == EXPLORE.Result.RESULT_COVERED, r.message
    assert r.coverage > 0.9


def test_explore_flies_a_lane_up_to_an_obstacle_holding_its_end(stack) -> None:  # type: ignore[no-untyped-def]
    rig, mission = stack
    # the area's east edge is the wall (x = 5.05 m): every lane's east end is inside it
    goal = interfaces.new(EXPLORE.Goal, area=area(1.0, 1.0, 5.05, 2.5), altitude=1.5)
    r = run_goal(rig, mission.explore, goal, 120.0)
    assert r.success and r.result == EXPLORE.Result.RESULT_COVERED, r.message
    assert "0 skipped" in r.message
    flown = np.array(mission.path)
    for lane_y in (1.0, 1.75, 2.5):
        on_lane = flown[np.abs(flown[:, 1] - lane_y) < 0.1]
        assert on_lane[:, 0].max() > 4.3, lane_y  # flown up to the wall's inflation
    assert flown[:, 0].max() < 5.05 - 0.35


def test_a_lane_end_in_a_block_behind_the_wall_is_replaced_on_this_side(stack) -> None:  # type: ignore[no-untyped-def]
    rig, mission = stack
    # the lanes' east ends are inside a block beyond the wall: the nearest reachable points
    # toward them are just past the block, but only round the wall's far end; the lane is
    # flown up to the wall instead
    block = np.array([(x, y, z) for x in np.arange(7.45, 8.6, 0.1)
                      for y in np.arange(0.45, 2.2, 0.1) for z in np.arange(0.05, 4.0, 0.1)])
    mission.map_pub.publish(cloud_msg(np.vstack([WALL, block]), Time(0).to_msg(), "map"))
    rig.ex.spin_for(0.5)
    goal = interfaces.new(EXPLORE.Goal, area=area(1.0, 1.0, 8.0, 1.75), altitude=1.5)
    r = run_goal(rig, mission.explore, goal, 120.0)
    assert r.success and "0 skipped" in r.message, r.message
    flown = np.array(mission.path)
    assert flown[:, 0].max() < 5.05 - 0.35  # never round the wall
    assert flown[np.abs(flown[:, 1] - 1.0) < 0.1, 0].max() > 4.3  # the lane up to it


def test_explore_sweeps_again_across_while_the_wanted_marker_is_not_seen(stack) -> None:  # type: ignore[no-untyped-def]
    rig, mission = stack
    goal = interfaces.new(EXPLORE.Goal, area=area(1.0, 1.0, 4.0, 2.5), altitude=1.5,
                          stop_marker_ids=[19])
    r = run_goal(rig, mission.explore, goal, 240.0)
    assert r.success and r.result == EXPLORE.Result.RESULT_COVERED, r.message
    assert "in 3 sweeps" in r.message  # config/navigator.yaml's explore_sweeps
    flown = np.array(mission.path)
    step = np.diff(flown[:, :2], axis=0)
    inside = (flown[1:, 0] > 1.5) & (flown[1:, 0] < 3.5)  # away from the x edges
    north_south = inside & (np.abs(step[:, 1]) > 5 * np.abs(step[:, 0])) & (
        np.abs(step[:, 1]) > 1e-3)
    assert north_south.sum() > 20  # lanes along y inside the area: the sweep across


def test_explore_stops_when_a_wanted_marker_is_seen(stack) -> None:  # type: ignore[no-untyped-def]
    rig, mission = stack
    goal = interfaces.new(EXPLORE.Goal, area=area(1.0, 1.0, 4.0, 4.0), altitude=1.5,
                          stop_marker_ids=[14, 19])
    state = {"sent": False}

    def marker_after_5_s() -> None:
        if rig.t() > 5.0 and not state["sent"]:
            mission.see_marker(12)  # not wanted: keeps going
            mission.see_marker(19)
            state["sent"] = True

    start = rig.t()
    r = run_goal(rig, mission.explore, goal, 120.0, during=marker_after_5_s)
    assert r.success and r.result == EXPLORE.Result.RESULT_MARKER_FOUND, r.message
    assert list(r.markers_found) == [12, 19]
    assert rig.t() - start < 15.0  # stopped right away, not after the whole area
    assert r.coverage < 0.9


def test_an_explore_goal_after_a_canceled_one_goes_on_where_that_one_stopped(stack) -> None:  # type: ignore[no-untyped-def]
    """The mission's HOLD cancels the explore goal, its RESUME sends the same goal again:
    the navigator goes on from the waypoint it was flying to, not from the first."""
    rig, mission = stack
    goal = interfaces.new(EXPLORE.Goal, area=area(1.0, 1.0, 4.0, 4.0), altitude=1.5)
    waypoints: list[list[tuple[float, float]]] = [[], []]

    def feedback(i: int) -> Any:
        def on(msg: Any) -> None:
            p = msg.feedback.next_waypoint
            if not waypoints[i] or waypoints[i][-1] != (p.x, p.y):
                waypoints[i].append((p.x, p.y))
        return on

    handle = rig.wait(mission.explore.send_goal_async(goal, feedback(0)), 2.0)
    result = handle.get_result_async()
    t_end = rig.t() + 60.0
    while len(waypoints[0]) < 3 and rig.t() < t_end:  # on the way to the third waypoint
        rig.ex.spin_for(0.2)
    assert len(waypoints[0]) == 3 and not result.done()
    rig.wait(handle.cancel_goal_async(), 2.0)
    canceled = rig.wait(result, 5.0).result
    assert canceled.result == EXPLORE.Result.RESULT_CANCELED, canceled.message
    handle = rig.wait(mission.explore.send_goal_async(goal, feedback(1)), 2.0)
    r = rig.wait(handle.get_result_async(), 120.0).result
    assert r.success and r.result == EXPLORE.Result.RESULT_COVERED, r.message
    assert waypoints[1][0] == waypoints[0][2]  # the waypoint it was flying to
    assert not set(waypoints[0][:2]) & set(waypoints[1])  # those reached: not again
    # the waypoints flown before count too (the first, at the vehicle, has no feedback)
    flown, of = (int(n) for n in r.message.split(" ", 1)[0].split("/"))
    assert flown == of >= len(waypoints[0]) - 1 + len(waypoints[1]), r.message
    assert r.coverage > 0.9


def test_a_pillar_seen_late_on_the_leg_makes_it_replan_round_it(stack) -> None:  # type: ignore[no-untyped-def]
    rig, mission = stack
    # a thin pillar on the straight line y = 6.5 m, published once the leg has started
    pillar = np.array([(x, y, z) for x in (2.95, 3.05) for y in np.arange(6.35, 6.7, 0.1)
                       for z in np.arange(0.05, 4.0, 0.1)])
    rig.fcu.position = np.array([0.8, 6.5, 1.5])
    rig.ex.spin_for(0.5)
    goal = interfaces.new(NAVIGATE.Goal, goal=interfaces.new(
        "geometry_msgs/msg/Point", x=9.0, y=6.5, z=1.5), yaw=math.nan)
    state = {"seen": False}

    def pillar_seen_at_1_m() -> None:
        if not state["seen"] and rig.fcu.position[0] > 1.2:
            mission.map_pub.publish(cloud_msg(np.vstack([WALL, pillar]), Time(0).to_msg(),
                                              "map"))
            state["seen"] = True

    r = run_goal(rig, mission.navigate, goal, 60.0, during=pillar_seen_at_1_m)
    assert r.success, r.message
    flown = np.array(mission.path)
    beside = flown[np.abs(flown[:, 0] - 3.0) < 0.1]
    assert len(beside) and np.min(np.abs(beside[:, 1] - 6.5)) > 0.35  # never through it


class TurningFcu(ScriptedFcu):
    """The scripted FCU, whose heading also follows the setpoint's yaw at once (the turn
    action ends when the vehicle faces the leg)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.yaw = 0.0
        self._odometry_pub = self.odometry_pub
        self.odometry_pub = self  # type: ignore[assignment]  # publish() below

    def publish(self, msg: Any) -> None:
        if self.setpoint is not None and math.isfinite(self.setpoint.yaw):
            self.yaw = float(self.setpoint.yaw)
        msg.pose.pose.orientation.w = math.cos(self.yaw / 2.0)
        msg.pose.pose.orientation.z = math.sin(self.yaw / 2.0)
        self._odometry_pub.publish(msg)


def fly_north_revealing(monkeypatch: Any, hidden: np.ndarray) -> tuple[Any, np.ndarray]:
    """Facing east at (1, 1) m, navigate to (1, 6) m, north: the vehicle turns first, and
    ``hidden`` reaches the map 0.5 s after it faces north (as the depth camera's clouds
    do). (the navigate result, the flown path)."""
    monkeypatch.setattr(rig_module, "ScriptedFcu", TurningFcu)
    rig = make_rig(flying_at=(1.0, 1.0, 1.5))
    ctx = rig.ex.context
    finder = PathFinderNode(context=ctx, parameter_overrides=FIELD)
    nav = NavigatorNode(context=ctx, parameter_overrides=NAV_OVERRIDES | {
        "turn_first_angle": 0.785})
    mission = Mission(context=ctx)
    for node in (finder, nav, mission):
        rig.ex.add_node(node)
    mission.map_pub.publish(cloud_msg(WALL, Time(0).to_msg(), "map"))
    rig.ex.spin_for(0.5)
    state: dict[str, float] = {}

    def camera() -> None:  # the map holds ``hidden`` 0.5 s after the vehicle faces north
        facing = abs(rig.fcu.yaw - math.pi / 2) < 0.05  # type: ignore[attr-defined]
        if facing and "t" not in state:
            state["t"] = rig.t()
        if "t" in state and "sent" not in state and rig.t() >= state["t"] + 0.5:
            mission.map_pub.publish(cloud_msg(np.vstack([WALL, hidden]),
                                              rig.ex.now().to_msg(), "map"))
            state["sent"] = rig.t()

    goal = interfaces.new(NAVIGATE.Goal, goal=interfaces.new(
        "geometry_msgs/msg/Point", x=1.0, y=6.0, z=1.5), yaw=math.nan)
    handle = rig.wait(mission.navigate.send_goal_async(goal), 2.0)
    result = handle.get_result_async()
    t_end = rig.t() + 60.0
    while not result.done() and rig.t() < t_end:
        rig.ex.spin_for(0.05)
        camera()
    assert "sent" in state, "the vehicle never faced north"
    assert result.done(), "no result after 60 s"
    return result.result().result, np.array(mission.path)


def test_after_a_turn_it_plans_again_on_what_the_camera_sees_before_flying_on(
        monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """What it faces after the turn is a wall across the leg: the navigator waits for a
    map captured after the turn and goes round, rather than flying the leg planned before
    it looked."""
    hidden = np.array([(x, 2.55, z) for x in np.arange(0.05, 3.0, 0.1)
                       for z in np.arange(0.05, 4.0, 0.1)])
    r, flown = fly_north_revealing(monkeypatch, hidden)
    assert r.success, r.message
    on_the_old_leg = flown[(flown[:, 0] < 1.2) & (flown[:, 1] < 2.55)]
    assert on_the_old_leg[:, 1].max() < 1.3  # it did not set off north toward the wall
    beside = flown[flown[:, 0] < 3.0]
    assert np.min(np.abs(beside[:, 1] - 2.55)) > 0.35  # and went round its end


def test_a_goal_found_inside_a_block_after_the_turn_stops_it_with_no_path(
        monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """Random arena 1's crash: the goal turns out to be inside a block (its faces seen
    only after the turn, its inside unknown). The re-plan finds no path, and the navigator
    stops and says so instead of flying on along the path planned before it looked."""
    box = np.array([(x, y, z) for x in np.arange(0.05, 2.0, 0.1)
                    for y in np.arange(4.95, 7.0, 0.1) for z in np.arange(0.05, 4.0, 0.1)
                    if min(x - 0.05, 1.95 - x, y - 4.95, 6.95 - y) < 0.05])  # its faces
    r, flown = fly_north_revealing(monkeypatch, box)
    assert not r.success and r.result == NAVIGATE.Result.RESULT_NO_PATH, r.message
    assert "blocked" in r.message
    assert flown[:, 1].max() < 4.95 - 0.35  # it never flew into the block
