"""The faults of issue 22's second slice, each read where it acts: the vision stream
(jump, delay), the link (latency, loss), the XRCE agent's clock (time sync), the sensors'
publishers (dark cameras), the MuJoCo model (a marker gone, the light down). A SITL on
the pad, nothing flying."""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np
import pytest

from runtime import Node, Time, qos_profile_sensor_data
from sim.arena import Lighting
from sim.fault_spec import parse_faults
from sim.faults import FaultInstallError, install_faults
from sim.fcu.link import LinkDirection
from sim.fcu.sitl import Sitl, build_sitl
from sim.mjcf import LIGHTING_PRESETS, pad_geom_name, robot_body_name
from sim.sensors import (
    DEPTH_POINTS_TOPIC,
    DOWN_IMAGE_TOPIC,
    SimSensorsNode,
    image_msg,
    point_cloud_msg,
)
from sim.vision import VISION_POSE_TOPIC


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
    return Listener(VISION_POSE_TOPIC, "geometry_msgs/msg/PoseWithCovarianceStamped",
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
    images = Listener(DOWN_IMAGE_TOPIC, "sensor_msgs/msg/Image", context=sitl.executor.context)
    clouds = Listener(DEPTH_POINTS_TOPIC, "sensor_msgs/msg/PointCloud2",
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
