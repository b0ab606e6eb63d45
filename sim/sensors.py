"""The simulator's sensors as ROS topics: cameras, depth point cloud and /clock.

:class:`SimSensorsNode` owns the publishers; the world loop drives the parts below at
their rates, so each sample is published at its exact simulated capture time. Cameras
render only while someone subscribes (software rendering costs ~25 ms a frame).

Frames: ``down_camera`` image up = body forward, image right = body right (seed 003
eq. 2 holds as written); ``depth_camera`` points are in the camera's FLU frame
(x forward, ROS ``camera_link``).

Rates and noise are the node's parameters (:class:`SensorParams`, ``config/sim_sensors.yaml``);
the cameras' image size, field of view and mounting are the airframe's
(:class:`~sim.quadrotor.QuadrotorParams`), compiled into the MuJoCo model.
"""

from __future__ import annotations

import functools
from concurrent.futures import Future
from dataclasses import dataclass
from typing import Any

import numpy as np

import interfaces
from interfaces import graph
from runtime import Node, Time
from runtime.clock import seconds_to_ns
from runtime.errors import ParameterError
from runtime.parameters import param, validate_parameters
from sim.camera_model import CameraSensorModel, camera_model_params, motion_blur_px
from sim.mjcf import DOWN_CAMERA
from sim.render import CameraIntrinsics, DepthPointCloud, Image, Points, SceneRenderer
from sim.scene import quad_state
from sim.world import Scene, divides

DOWN_FRAME = "down_camera"
DEPTH_FRAME = "depth_camera"

_FLOAT32 = 7  # sensor_msgs/PointField.FLOAT32


def image_msg(image: Image, stamp: Time, frame_id: str) -> Any:
    """An rgb8 sensor_msgs/Image of an (H, W, 3) uint8 array."""
    height, width, _ = image.shape
    return interfaces.new(
        "sensor_msgs/msg/Image",
        header=interfaces.new("std_msgs/msg/Header", stamp=stamp.to_msg(), frame_id=frame_id),
        height=height,
        width=width,
        encoding="rgb8",
        step=3 * width,
        data=np.ascontiguousarray(image, dtype=np.uint8).reshape(-1),
    )


def image_from_msg(msg: Any) -> Image:
    """The (H, W, 3) uint8 array of an rgb8 sensor_msgs/Image."""
    if msg.encoding != "rgb8":
        raise ValueError(f"expected an rgb8 image, got {msg.encoding!r}")
    return np.asarray(msg.data, dtype=np.uint8).reshape(msg.height, msg.width, 3)


def camera_info_msg(intrinsics: CameraIntrinsics, stamp: Time, frame_id: str) -> Any:
    """sensor_msgs/CameraInfo of an ideal pinhole camera (no distortion)."""
    k = intrinsics.matrix()
    p = np.hstack([k, np.zeros((3, 1))])
    return interfaces.new(
        "sensor_msgs/msg/CameraInfo",
        header=interfaces.new("std_msgs/msg/Header", stamp=stamp.to_msg(), frame_id=frame_id),
        height=intrinsics.height,
        width=intrinsics.width,
        distortion_model="plumb_bob",
        d=np.zeros(5),
        k=k.reshape(-1),
        r=np.eye(3).reshape(-1),
        p=p.reshape(-1),
    )


def point_cloud_msg(points: Points, stamp: Time, frame_id: str) -> Any:
    """An unorganised sensor_msgs/PointCloud2 with float32 x, y, z."""
    pts = np.ascontiguousarray(points, dtype=np.float32).reshape(-1, 3)
    fields = [
        interfaces.new("sensor_msgs/msg/PointField", name=n, offset=4 * i, datatype=_FLOAT32,
                       count=1)
        for i, n in enumerate("xyz")
    ]
    return interfaces.new(
        "sensor_msgs/msg/PointCloud2",
        header=interfaces.new("std_msgs/msg/Header", stamp=stamp.to_msg(), frame_id=frame_id),
        height=1,
        width=len(pts),
        fields=fields,
        is_bigendian=False,
        point_step=12,
        row_step=12 * len(pts),
        data=pts.view(np.uint8).reshape(-1),
        is_dense=True,
    )


def points_from_msg(msg: Any) -> Points:
    """The (N, 3) float32 points of a PointCloud2 made by :func:`point_cloud_msg`."""
    names = [f.name for f in msg.fields[:3]]
    if names != ["x", "y", "z"] or msg.point_step != 12:
        raise ValueError(f"expected packed float32 x, y, z points, got fields {names}")
    return np.frombuffer(np.asarray(msg.data, dtype=np.uint8).tobytes(), dtype=np.float32).reshape(
        -1, 3
    )


SENSORS_NODE_NAME = "sim_sensors"
"""The sensors node, and its section in ``config/sim_sensors.yaml``."""


@dataclass(frozen=True)
class DownCameraParams:
    """The downward camera's frame rate (``down_camera`` in ``config/sim_sensors.yaml``)."""

    rate_hz: float = param(unit="Hz", range=(0.1, 1000.0))
    """Images per second (must divide the physics rate)."""
    latency_s: float = param(unit="s", range=(0.0, 1.0))
    """From exposure to the image on its topic (stamped at the exposure). Above 0 the
    frame is rendered on the render thread meanwhile; 0 renders it at once, in line."""

    def __post_init__(self) -> None:
        validate_parameters(self)


@dataclass(frozen=True)
class DepthCameraParams:
    """The depth camera's rate and noise (``depth_camera`` in ``config/sim_sensors.yaml``)."""

    rate_hz: float = param(unit="Hz", range=(0.1, 1000.0))
    """Point clouds per second (must divide the physics rate)."""
    noise_std: float = param(unit="m", range=(0.0, 1.0))
    """Gaussian noise on each pixel's depth, along its ray."""
    latency_s: float = param(unit="s", range=(0.0, 1.0))
    """From capture to the cloud on its topic (stamped at the capture). Above 0 the cloud
    is rendered and made on the render thread meanwhile; 0 makes it at once, in line."""

    def __post_init__(self) -> None:
        validate_parameters(self)


@dataclass(frozen=True)
class SensorParams:
    """The simulated sensors' rates and noise (``config/sim_sensors.yaml``)."""

    down_camera: DownCameraParams
    depth_camera: DepthCameraParams
    clock_rate_hz: float = param(unit="Hz", range=(0.1, 10000.0))
    """/clock messages per second (must divide the physics rate)."""

    def __post_init__(self) -> None:
        validate_parameters(self)


class SimSensorsNode(Node):
    """Publishes the simulated sensors; the world loop's parts decide when. Holds the
    sensors' parameters (:class:`SensorParams`)."""

    def __init__(self, *, clock: bool = True, **kwargs: Any) -> None:
        super().__init__(SENSORS_NODE_NAME, **kwargs)
        self.params = self.declare_params(SensorParams)
        self.down_image, self.down_info, self.depth_points = (
            self.create_publisher(t.type, t.name, t.qos)
            for t in (graph.CAMERA_DOWN_RAW, graph.CAMERA_DOWN_INFO, graph.CAMERA_DEPTH_POINTS))
        #: /clock (None without ``clock``: a vehicle on the wall clock publishes none)
        self.clock = (self.create_publisher(graph.CLOCK.type, graph.CLOCK.name, graph.CLOCK.qos)
                      if clock else None)
        self.stamp_offset_ns = 0
        """The stamps' clock minus simulated time [ns]: 0 in simulated time; a vehicle on
        the wall clock stamps as a camera driver on its host does (the host's clock)."""


@dataclass
class DownCamera:
    """The downward camera: an image and its camera_info at ``rate_hz``, rendered only
    while the image topic has subscribers."""

    node: SimSensorsNode
    renderer: SceneRenderer
    intrinsics: CameraIntrinsics
    rate_hz: float
    name: str = "down_camera"
    frames_rendered: int = 0
    sensor: CameraSensorModel | None = None  # None: the rendered frame as it is
    latency_s: float = 0.0
    """Exposure to publication; above 0 the frame renders on the render thread meanwhile
    (:meth:`SceneRenderer.render_later`), published ``latency_s`` later in simulated time
    and stamped at the exposure: the same image, at a fixed time, so runs stay
    deterministic."""

    def update(self, t_ns: int, scene: Scene) -> None:
        stamp = Time(t_ns + self.node.stamp_offset_ns)
        if self.node.down_info.get_subscription_count():
            self.node.down_info.publish(camera_info_msg(self.intrinsics, stamp, DOWN_FRAME))
        if not self.node.down_image.get_subscription_count():
            return
        self.frames_rendered += 1
        finish = None
        if self.sensor is not None:
            finish = functools.partial(self.sensor.apply,
                                       blur_px=self._blur_px(scene, self.sensor.exposure_s))
        if self.latency_s <= 0.0:
            image = self.renderer.down_image(scene.data)
            self._publish(image if finish is None else finish(image), stamp)
            return
        frame = self.renderer.render_later(scene.data, DOWN_CAMERA, finish)
        self.node.context.loop.call_at(
            t_ns + seconds_to_ns(self.latency_s), lambda: self._deliver(frame, stamp),
            (self.node.get_name(), "camera", graph.CAMERA_DOWN_RAW.name))

    def _deliver(self, frame: Future[Image], stamp: Time) -> None:
        if self.node in self.node.context.nodes:  # not destroyed while the frame was drawn
            self._publish(frame.result(), stamp)

    def _publish(self, image: Image, stamp: Time) -> None:
        self.node.down_image.publish(image_msg(image, stamp, DOWN_FRAME))


    def _blur_px(self, scene: Scene, exposure_s: float) -> tuple[float, float]:
        state = quad_state(scene.data, scene.index)
        w, x, y, z = state.quaternion
        r = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                      [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                      [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
        return motion_blur_px(r.T @ state.velocity, state.angular_velocity,
                              float(state.position[2]), self.intrinsics.fy, exposure_s)


@dataclass
class DepthCamera:
    """The forward depth camera as a noisy point cloud, rendered only when subscribed."""

    node: SimSensorsNode
    cloud: DepthPointCloud
    rate_hz: float
    name: str = "depth_camera"
    latency_s: float = 0.0
    """Capture to publication; above 0 the cloud is made on the render thread meanwhile
    and published ``latency_s`` later, stamped at the capture (as :class:`DownCamera`)."""

    def update(self, t_ns: int, scene: Scene) -> None:
        if not self.node.depth_points.get_subscription_count():
            return
        stamp = Time(t_ns + self.node.stamp_offset_ns)
        if self.latency_s <= 0.0:
            self._publish(self.cloud.points(scene.data), stamp)
            return
        cloud = self.cloud.points_later(scene.data)
        self.node.context.loop.call_at(
            t_ns + seconds_to_ns(self.latency_s), lambda: self._deliver(cloud, stamp),
            (self.node.get_name(), "camera", graph.CAMERA_DEPTH_POINTS.name))

    def _deliver(self, cloud: Future[Points], stamp: Time) -> None:
        if self.node in self.node.context.nodes:  # not destroyed while it was made
            self._publish(cloud.result(), stamp)

    def _publish(self, points: Points, stamp: Time) -> None:
        self.node.depth_points.publish(point_cloud_msg(points, stamp, DEPTH_FRAME))


@dataclass
class ClockPublisher:
    """/clock, the simulated time, for tools that follow it."""

    node: SimSensorsNode
    rate_hz: float
    name: str = "clock"

    def update(self, t_ns: int, scene: Scene) -> None:
        assert self.node.clock is not None  # sensor_parts adds this part only with a /clock
        self.node.clock.publish(
            interfaces.new("rosgraph_msgs/msg/Clock", clock=Time(t_ns).to_msg())
        )


def sensor_parts(
    node: SimSensorsNode,
    renderer: SceneRenderer,
    scene: Scene,
    *,
    depth_noise_std: float | None = None,
    seed: int = 0,
    camera_hz: float | None = None,
    depth_hz: float | None = None,
) -> list[DownCamera | DepthCamera | ClockPublisher]:
    """The standard sensor set of the contest drone, ready for :func:`sim.world.run_world`.

    Rates and noise are the node's parameters unless given here. A node parameter whose
    rate does not divide the scene's physics rate raises ParameterError naming it.
    """
    params = node.params

    def rate(key: str, configured: float, given: float | None) -> float:
        if given is not None:
            return given  # run_world checks it (RateError naming the part)
        if not divides(configured, scene.physics_hz):
            raise ParameterError(
                f"{configured:g} Hz does not divide the physics rate {scene.physics_hz} Hz",
                key=f"{node.get_name()}.{key}")
        return configured

    noise = params.depth_camera.noise_std if depth_noise_std is None else depth_noise_std
    sensor = CameraSensorModel(camera_model_params(), scene.arena.lighting, seed + 3)
    parts: list[DownCamera | DepthCamera | ClockPublisher] = [
        DownCamera(node, renderer, CameraIntrinsics.from_camera(scene.quad.down_camera),
                   rate_hz=rate("down_camera.rate_hz", params.down_camera.rate_hz, camera_hz),
                   sensor=sensor, latency_s=params.down_camera.latency_s),
        DepthCamera(node, DepthPointCloud(renderer, scene.quad.depth_camera,
                                          noise_std=noise, seed=seed),
                    rate_hz=rate("depth_camera.rate_hz", params.depth_camera.rate_hz, depth_hz),
                    latency_s=params.depth_camera.latency_s),
    ]
    if node.clock is not None:
        parts.append(ClockPublisher(node, rate_hz=rate("clock_rate_hz", params.clock_rate_hz,
                                                       None)))
    return parts
