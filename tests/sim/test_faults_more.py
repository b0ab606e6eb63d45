"""The faults of issue 22's second slice, each read where it acts: the vision stream
(jump, delay), the link (latency, loss), the XRCE agent's clock (time sync), the sensors'
publishers (dark cameras), the MuJoCo model (a marker gone, the light down), the robots'
motion (one driving across). A SITL on the pad, nothing flying."""

from __future__ import annotations

import math
from typing import Any

import mujoco
import numpy as np
import pytest

from interfaces import graph
from runtime import Node, Time, qos_profile_sensor_data
from sim.arena import ROBOT_SIZE, Lighting, default_arena, robot_pose
from sim.fault_spec import parse_fault, parse_faults
from sim.faults import FaultInstallError, across_drive, install_faults
from sim.fcu.link import LinkDirection
from sim.fcu.sitl import Sitl, build_sitl
from sim.mjcf import LIGHTING_PRESETS, pad_geom_name, robot_body_name
from sim.scene import quad_state
from sim.sensors import (
    SimSensorsNode,
    image_msg,
    point_cloud_msg,
)


@pytest.fixture
def sitl() -> Sitl:
    return build_sitl(seed=3)


class Listener(Node):
    def __init__(self, topic: str, type_name: str, **kwargs: Any) -> None:
        super().__init__("fault_listener", **kwargs)
        self.got: list[tuple[int, Any]] = []
        self.create_subscription(type_name, topic,
                                 lambda m: self.got.append((self.now().nanoseconds, m)),
                                 qos_profile_sensor_data)


def _poses(sitl: Sitl) -> Listener:
    return Listener(graph.SIM_VISION_POSE.name, "geometry_msgs/msg/PoseWithCovarianceStamped",
                    context=sitl.executor.context)


def _xyz(msg: Any) -> np.ndarray:
    p = msg.pose.pose.position
    return np.array([p.x, p.y, p.z])


def test_vio_jump_shifts_every_pose_from_its_time_on(sitl: Sitl) -> None:
    listener = _poses(sitl)
    install_faults(sitl, parse_faults(["vio_jump@0.5,x=1.5,y=-0.5"]))
    sitl.run(1.0)
    stamp = [(m.header.stamp.sec * 10**9 + m.header.stamp.nanosec, _xyz(m)) for _, m in
             listener.got]
    before = np.array([p for t, p in stamp if t < 500_000_000])
    after = np.array([p for t, p in stamp if t >= 500_000_000])
    assert len(before) > 5 and len(after) > 5
    np.testing.assert_allclose(after.mean(axis=0) - before.mean(axis=0), [1.5, -0.5, 0.0],
                               atol=0.02)


def test_vio_delay_publishes_late_in_its_window_only(sitl: Sitl) -> None:
    listener = _poses(sitl)
    install_faults(sitl, parse_faults(["vio_delay@0.4:0.4,delay_ms=250"]))
    sitl.run(1.5)
    lags = [(t - (m.header.stamp.sec * 10**9 + m.header.stamp.nanosec)) / 1e9
            for t, m in listener.got]
    stamps = [(m.header.stamp.sec + m.header.stamp.nanosec / 1e9) for _, m in listener.got]
    base = min(lags)
    inside = [lag for s, lag in zip(stamps, lags, strict=True) if 0.4 <= s < 0.8]
    outside = [lag for s, lag in zip(stamps, lags, strict=True) if s < 0.4 or s >= 0.8]
    assert inside and outside
    assert all(lag == pytest.approx(base + 0.25, abs=1e-6) for lag in inside)
    assert all(lag == pytest.approx(base, abs=1e-6) for lag in outside)


def test_latency_spike_delays_every_message_both_ways(sitl: Sitl) -> None:
    install_faults(sitl, parse_faults(["latency_spike@0.5:1,latency_ms=400"]))
    link = sitl.link

    def delay_ns(direction: LinkDirection) -> int:
        t = sitl.executor.now_ns()
        delivery = link.send(direction, t, 0)
        assert delivery is not None
        return delivery - t

    sitl.run(0.3)
    quiet = [delay_ns(d) for d in LinkDirection]
    sitl.run(0.3)
    spiked = [delay_ns(d) for d in LinkDirection]
    for q, s in zip(quiet, spiked, strict=True):
        assert s - q == pytest.approx(400e6, abs=20e6)
    sitl.run(1.0)
    assert link.extra_latency_us == 0.0


def test_packet_burst_loses_that_share_both_ways_then_stops(sitl: Sitl) -> None:
    install_faults(sitl, parse_faults(["packet_burst@0.1:2,loss=0.5"]))
    sitl.run(0.2)
    t = 200_000_000
    lost = {d: 0 for d in LinkDirection}
    for i in range(2000):
        for d in LinkDirection:
            lost[d] += sitl.link.send(d, t + i, 10) is None
    assert all(0.45 < n / 2000 < 0.55 for n in lost.values()), lost
    sitl.run(2.0)
    assert sitl.link.extra_loss_probability == 0.0


def test_clock_jump_moves_the_agents_time_sync_answers(sitl: Sitl) -> None:
    install_faults(sitl, parse_faults(["clock_jump@0.5,offset_ms=-2000"]))
    sitl.run(0.6)
    assert sitl.agent.clock_offset_ns == -2_000_000_000
    replies: list[Any] = []
    sitl.agent.inbox.put_timesync = replies.append  # type: ignore[method-assign,assignment]
    asked = sitl.executor.now_ns()
    sitl.agent.request_timesync(0, asked)
    sitl.executor.spin_for(0.1)
    (reply,) = replies
    assert asked <= reply.agent_time_ns + 2_000_000_000 <= sitl.executor.now_ns()


def _gid(sitl: Sitl, name: str) -> int:
    return mujoco.mj_name2id(sitl.scene.model, mujoco.mjtObj.mjOBJ_GEOM, name)


def test_pad_occluded_and_robot_absent_take_the_marker_texture_off(sitl: Sitl) -> None:
    arena = sitl.scene.arena
    pad = arena.pad_ids[-1]
    robot = arena.robots[0].marker_id
    pad_geom = _gid(sitl, pad_geom_name(pad))
    robot_geom = _gid(sitl, f"{robot_body_name(robot)}_marker")
    assert sitl.scene.model.geom_matid[pad_geom] >= 0
    install_faults(sitl, parse_faults([f"pad_occluded@0.2,pad={pad}",
                                       f"robot_absent@0.2,robot={robot}"]))
    sitl.run(0.1)
    assert sitl.scene.model.geom_matid[pad_geom] >= 0
    assert sitl.scene.model.geom_matid[robot_geom] >= 0
    sitl.run(0.2)
    assert sitl.scene.model.geom_matid[pad_geom] == -1
    assert sitl.scene.model.geom_matid[robot_geom] == -1
    other = _gid(sitl, pad_geom_name(arena.pad_ids[0]))
    assert sitl.scene.model.geom_matid[other] >= 0, "only that pad"


def test_a_marker_the_arena_lacks_is_refused_naming_it(sitl: Sitl) -> None:
    with pytest.raises(FaultInstallError, match="has pads"):
        install_faults(sitl, parse_faults(["pad_occluded@0,pad=99"]))
    with pytest.raises(FaultInstallError, match="robot=ID"):
        install_faults(sitl, parse_faults(["robot_absent@0"]))


def test_light_drop_sets_the_dark_preset(sitl: Sitl) -> None:
    dark = LIGHTING_PRESETS[Lighting.DARK]
    assert sitl.scene.model.vis.headlight.diffuse[0] != pytest.approx(dark.headlight_diffuse)
    install_faults(sitl, parse_faults(["light_drop@0.1"]))
    sitl.run(0.2)
    assert sitl.scene.model.vis.headlight.diffuse[0] == pytest.approx(dark.headlight_diffuse)
    assert sitl.scene.model.vis.headlight.ambient[0] == pytest.approx(dark.headlight_ambient)


def test_dark_cameras_need_the_sensors_and_publish_black_then_normal(sitl: Sitl) -> None:
    with pytest.raises(FaultInstallError, match="camera_dark: this run has no cameras"):
        install_faults(sitl, parse_faults(["camera_dark@0:1"]))
    sensors = SimSensorsNode(context=sitl.executor.context)
    images = Listener(graph.CAMERA_DOWN_RAW.name, "sensor_msgs/msg/Image",
                      context=sitl.executor.context)
    clouds = Listener(graph.CAMERA_DEPTH_POINTS.name, "sensor_msgs/msg/PointCloud2",
                      context=sitl.executor.context)
    install_faults(sitl, parse_faults(["camera_dark@0:1", "depth_dark@0"]), sensors=sensors)
    sitl.run(0.01)
    image = np.full(12, 200, dtype=np.uint8)
    sensors.down_image.publish(image_msg(image.reshape(2, 2, 3), Time(0), "down_camera"))
    sensors.depth_points.publish(point_cloud_msg(np.ones((5, 3), np.float32), Time(0), "d"))
    sitl.run(1.0)
    sensors.down_image.publish(image_msg(image.reshape(2, 2, 3), Time(0), "down_camera"))
    sensors.depth_points.publish(point_cloud_msg(np.ones((5, 3), np.float32), Time(0), "d"))
    sitl.executor.spin_for(0.01)
    (_, dark), (_, lit) = images.got
    assert dark.width == 2 and not np.asarray(dark.data).any(), "black, same size"
    assert np.asarray(lit.data).min() == 200, "the camera is back"
    assert [c.width for _, c in clouds.got] == [0, 0], "the depth camera stays dark"


def _robot_xy(sitl: Sitl, index: int) -> np.ndarray:
    mocap = sitl.scene.index.robot_mocap[index]
    return np.array(sitl.scene.data.mocap_pos[mocap][:2])


def test_robot_across_drives_the_nearest_robot_through_the_point_ahead_then_stops(
    sitl: Sitl,
) -> None:
    """On the pad the vehicle's path is along its heading: the robot nearest the point
    2 m ahead leaves its route where it is, drives straight through that point at its
    speed, 1 m further, and stops there; the other robots keep to their routes."""
    arena = sitl.scene.arena
    truth = quad_state(sitl.scene.data, sitl.scene.index)
    w, x, y, z = truth.quaternion.tolist()
    heading = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    ahead = truth.position[:2] + 2.0 * np.array([math.cos(heading), math.sin(heading)])
    at = 0.5
    routes = [np.array(robot_pose(r, at).xy) for r in arena.robots]
    index = int(np.argmin([np.linalg.norm(p - ahead) for p in routes]))
    start = routes[index]
    to_point = float(np.linalg.norm(ahead - start))
    speed = 1.0
    install_faults(sitl, parse_faults([f"robot_across@{at},ahead=2,beyond=1,speed={speed}"]))
    sitl.run(at)
    assert np.allclose(_robot_xy(sitl, index), start, atol=0.05), "still on its route"
    direction = (ahead - start) / to_point
    seen = []
    for _ in range(int((to_point + 1.0) / speed / 0.5) + 4):  # to the end, and 2 s more
        sitl.run(0.5)
        t = sitl.executor.now_ns() / 1e9
        p = _robot_xy(sitl, index)
        along = float((p - start) @ direction)
        off_line = float(np.linalg.norm(p - start - along * direction))
        assert off_line < 1e-6, f"{off_line:.3g} m off the line through the point ahead"
        assert along == pytest.approx(min(speed * (t - at), to_point + 1.0), abs=0.11)
        seen.append(along)
    assert min(abs(a - to_point) for a in seen) < 0.5 * speed, "passed the point ahead"
    assert seen[-1] == seen[-2] == pytest.approx(to_point + 1.0), "stopped 1 m past it"
    t = sitl.executor.now_ns() / 1e9
    for other, robot in enumerate(arena.robots):
        if other != index:
            assert np.allclose(_robot_xy(sitl, other), robot_pose(robot, t).xy, atol=0.05)


def test_robot_across_crosses_along_the_velocity_and_stops_at_the_field_edge() -> None:
    """Moving, the path is the velocity's, not the heading's; the drive past the
    crossing point ends where the field does (the robot's half-width inside)."""
    arena = default_arena()
    robot = arena.robots[0]
    fault = parse_fault(f"robot_across@3,robot={robot.marker_id},ahead=1,beyond=20")
    here = (3.0, 4.0)
    _, drive = across_drive(fault, 3.0, arena, here, (0.0, 2.0), heading=0.0)
    point = np.array([3.0, 5.0])  # 1 m north (the velocity), not east (the heading)
    start, end = np.array(drive.start), np.array(drive.end)
    assert np.allclose(start, robot_pose(robot, 3.0).xy)
    d = (end - start) / np.linalg.norm(end - start)
    along = float((point - start) @ d)
    assert np.linalg.norm(start + along * d - point) < 1e-9, "through the crossing point"
    half = ROBOT_SIZE[0] / 2.0
    size_x, size_y = arena.field.size[0], arena.field.size[1]
    assert half - 1e-9 <= end[0] <= size_x - half + 1e-9
    assert half - 1e-9 <= end[1] <= size_y - half + 1e-9
    assert np.linalg.norm(end - point) < 20.0, "cut short by the field"
    assert min(end[0] - half, size_x - half - end[0], end[1] - half,
               size_y - half - end[1]) < 1e-9, "on the field's edge"
    assert drive.pose(3.0 + 1e6).xy == pytest.approx(tuple(end))


def test_robot_across_needs_a_robot_of_the_arena(sitl: Sitl) -> None:
    with pytest.raises(FaultInstallError, match="has robots"):
        install_faults(sitl, parse_faults(["robot_across@0,robot=999"]))
