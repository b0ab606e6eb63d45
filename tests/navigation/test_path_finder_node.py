"""The path finder node through its topics: /map/points in, /navigation/plan_path out."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import interfaces
from interfaces import graph
from navigation.cloud_msgs import cloud_msg, cloud_points
from navigation.path_finder_node import PLAN_PATH, PathFinderNode, path_points
from runtime import DeterministicExecutor, Node, ParameterError, Time, qos_profile_default

R = PLAN_PATH.Response
FIELD = {"field_min": [0.0, 0.0, 0.0], "field_max": [6.0, 4.0, 2.0]}
# a wall at x = 3 m from y = 0 to 3 m, full height: the way round is at the north
WALL = np.array([(3.05, y, z) for y in np.arange(0.05, 3.0, 0.1)
                 for z in np.arange(0.05, 2.0, 0.1)])


class Client(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("test_client", **kwargs)
        self.map_pub = self.create_publisher("sensor_msgs/msg/PointCloud2", "/map/points",
                                             qos_profile_default)
        self.plan = self.create_client(PLAN_PATH, graph.PLAN_PATH.name)
        self.health: Any = None
        self.create_subscription("quadmission_interfaces/msg/HealthReport",
                                 "/path_finder/health", self._on_health, qos_profile_default)

    def _on_health(self, msg: Any) -> None:
        self.health = msg


@pytest.fixture
def rig() -> tuple[DeterministicExecutor, Client, PathFinderNode]:
    ex = DeterministicExecutor()
    finder = PathFinderNode(context=ex.context, parameter_overrides=FIELD)
    client = Client(context=ex.context)
    ex.add_node(finder)
    ex.add_node(client)
    return ex, client, finder


def ask(ex: DeterministicExecutor, client: Client, start: tuple[float, ...],
        goal: tuple[float, ...], clearance: float = 0.0) -> Any:
    request = interfaces.new(PLAN_PATH.Request, clearance=clearance,
                             start=interfaces.new("geometry_msgs/msg/Point", x=start[0],
                                                  y=start[1], z=start[2]),
                             goal=interfaces.new("geometry_msgs/msg/Point", x=goal[0],
                                                 y=goal[1], z=goal[2]))
    future = client.plan.call_async(request)
    assert ex.spin_until_future_complete(future, 2.0)
    return future.result()


def test_cloud_messages_round_trip() -> None:
    msg = cloud_msg(WALL, Time(5).to_msg(), "map")
    assert np.allclose(cloud_points(msg), WALL, atol=1e-6)


def test_no_map_then_a_path_around_the_wall(rig) -> None:  # type: ignore[no-untyped-def]
    ex, client, _finder = rig
    first = ask(ex, client, (1.0, 1.0, 1.0), (5.0, 1.0, 1.0))
    assert first.result == R.RESULT_NO_MAP and not first.success and "no map" in first.message
    client.map_pub.publish(cloud_msg(WALL, Time(0).to_msg(), "map"))
    ex.spin_for(0.1)
    ok = ask(ex, client, (1.0, 1.0, 1.0), (5.0, 1.0, 1.0))
    assert ok.success and ok.result == R.RESULT_OK
    pts = path_points(ok.path)
    assert pts[0].tolist() == [1.0, 1.0, 1.0] and pts[-1].tolist() == [5.0, 1.0, 1.0]
    assert pts[:, 1].max() > 3.0  # round the wall's end
    assert ok.length == pytest.approx(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())
    assert ok.path.header.frame_id == "map"


def test_each_planning_error_has_its_result_code(rig) -> None:  # type: ignore[no-untyped-def]
    ex, client, _ = rig
    client.map_pub.publish(cloud_msg(WALL, Time(0).to_msg(), "map"))
    ex.spin_for(0.1)
    cases = [((3.05, 1.0, 1.0), (5.0, 1.0, 1.0), R.RESULT_START_OCCUPIED, "StartOccupied"),
             ((1.0, 1.0, 1.0), (3.1, 1.5, 1.0), R.RESULT_GOAL_OCCUPIED, "GoalOccupied"),
             ((1.0, 1.0, 1.0), (9.0, 1.0, 1.0), R.RESULT_OUT_OF_BOUNDS, "outside the field"),
             ((1.0, 1.0, float("nan")), (5.0, 1.0, 1.0), R.RESULT_OUT_OF_BOUNDS, "finite")]
    for start, goal, code, words in cases:
        r = ask(ex, client, start, goal)
        assert (r.result, r.success) == (code, False), r.message
        assert words in r.message and len(r.path.poses) == 0


def test_a_larger_clearance_closes_the_gap(rig) -> None:  # type: ignore[no-untyped-def]
    ex, client, _ = rig
    client.map_pub.publish(cloud_msg(WALL, Time(0).to_msg(), "map"))
    ex.spin_for(0.1)
    # the gap north of the wall is 1 m (y 3..4, less the boundary cube): 0.6 m closes it
    r = ask(ex, client, (1.0, 1.0, 1.0), (5.0, 1.0, 1.0), clearance=0.6)
    assert r.result == R.RESULT_NO_PATH and "NoPathFound" in r.message


def test_health_reports_the_map(rig) -> None:  # type: ignore[no-untyped-def]
    ex, client, _ = rig
    ex.spin_for(1.1)
    assert client.health is not None and client.health.modules[0].message == "no map yet"
    client.map_pub.publish(cloud_msg(WALL, Time(0).to_msg(), "map"))
    ex.spin_for(1.1)
    assert client.health.level == 0 and client.health.modules[0].name == "path_finder"


def test_unknown_space_as_occupied_is_refused_without_observations() -> None:
    ex = DeterministicExecutor()
    with pytest.raises(ParameterError, match="unknown_is_occupied"):
        PathFinderNode(context=ex.context,
                       parameter_overrides=FIELD | {"unknown_is_occupied": True})


def test_the_search_limit_is_a_count_so_a_long_detour_times_out_the_same_way_every_time() -> None:
    ex = DeterministicExecutor()
    finder = PathFinderNode(context=ex.context,
                            parameter_overrides=FIELD | {"max_expansions": 1000})
    client = Client(context=ex.context)
    ex.add_node(finder)
    ex.add_node(client)
    client.map_pub.publish(cloud_msg(WALL, Time(0).to_msg(), "map"))
    ex.spin_for(0.1)
    replies = [ask(ex, client, (1.0, 1.0, 1.0), (5.0, 1.0, 1.0)) for _ in range(2)]
    for r in replies:
        assert not r.success and "PlanningTimedOut" in r.message, r.message
    assert replies[0].message == replies[1].message


def test_a_new_map_updates_the_graph_and_the_path_carries_its_stamp(rig) -> None:  # type: ignore[no-untyped-def]
    ex, client, finder = rig
    short = WALL[WALL[:, 1] < 1.5]  # the wall's south half: y = 3 m passes its end
    client.map_pub.publish(cloud_msg(short, Time(3_000_000_000).to_msg(), "map"))
    ex.spin_for(0.1)
    before = ask(ex, client, (1.0, 3.0, 1.0), (5.0, 3.0, 1.0))
    assert before.success and len(path_points(before.path)) == 2  # straight past its end
    assert Time.from_msg(before.path.header.stamp) == Time(3_000_000_000)
    # the camera sees the rest of the wall: the graph is updated, not rebuilt
    client.map_pub.publish(cloud_msg(WALL, Time(4_000_000_000).to_msg(), "map"))
    ex.spin_for(0.1)
    after = ask(ex, client, (1.0, 3.0, 1.0), (5.0, 3.0, 1.0))
    assert after.success and path_points(after.path)[:, 1].max() > 3.3  # round the new end
    assert Time.from_msg(after.path.header.stamp) == Time(4_000_000_000)
    assert (finder.graph_builds, finder.graph_updates) == (1, 1)


def test_a_restarted_mapping_nodes_smaller_map_does_not_erase_the_wall(
        rig: tuple[DeterministicExecutor, Client, PathFinderNode]) -> None:
    # mapping died and came back empty: its first maps hold a corner of the field only.
    # The map only grows, so the path finder keeps the wall the dead one had seen.
    ex, client, finder = rig
    client.map_pub.publish(cloud_msg(WALL, Time(1).to_msg(), "map"))
    ex.spin_for(0.1)
    corner = np.array([(0.55, 3.55, 0.55)])
    client.map_pub.publish(cloud_msg(corner, Time(2).to_msg(), "map"))
    ex.spin_for(0.1)
    assert len(finder.map_points()) == len(WALL) + 1
    response = ask(ex, client, (1.0, 1.0, 1.0), (5.0, 1.0, 1.0))
    assert response.success
    assert max(p[1] for p in path_points(response.path)) > 2.9  # round the wall, north


def test_an_empty_map_is_free_space_and_no_map_is_none(rig) -> None:  # type: ignore[no-untyped-def]
    """The start pad faces open floor: the mapping's first map holds no point. That is a
    map (free space, seen), so the path finder is ready and plans straight on it; only
    before any map is there "no map yet"."""
    ex, client, finder = rig
    ex.spin_for(1.1)
    assert client.health.level != 0 and client.health.modules[0].message == "no map yet"
    assert ask(ex, client, (1.0, 1.0, 1.0), (5.0, 1.0, 1.0)).result == R.RESULT_NO_MAP
    client.map_pub.publish(cloud_msg(np.empty((0, 3)), Time(2_000_000_000).to_msg(), "map"))
    ex.spin_for(1.1)
    assert client.health.level == 0 and client.health.modules[0].message == ""
    straight = ask(ex, client, (1.0, 1.0, 1.0), (5.0, 1.0, 1.0))
    assert straight.success, straight.message
    assert len(path_points(straight.path)) == 2
    assert Time.from_msg(straight.path.header.stamp) == Time(2_000_000_000)
    # the vehicle turns and sees the wall: the free graph is updated, and the path goes round
    client.map_pub.publish(cloud_msg(WALL, Time(3_000_000_000).to_msg(), "map"))
    ex.spin_for(0.1)
    around = ask(ex, client, (1.0, 1.0, 1.0), (5.0, 1.0, 1.0))
    assert around.success and path_points(around.path)[:, 1].max() > 3.0
    assert (finder.graph_builds, finder.graph_updates) == (1, 1)
