"""A simulated visual-odometry measurement (the role ORB-SLAM2 plays in seed 003).

:class:`VisionPose` is a world part: at ``rate_hz`` it takes the vehicle's true pose,
adds white noise and a slowly drifting offset (a random walk, as odometry drifts), and
publishes it on ``/sim/vision/pose`` (geometry_msgs/PoseWithCovarianceStamped, ``map``
frame, ENU/FLU) after a processing ``latency_s``, stamped with the time the pose was
true. Setting ``tracking`` to False cuts the stream, as a lost SLAM track does;
``offset`` shifts it (a relocalisation jump), ``extra_latency_s`` delays it. The
companion node that forwards it to the flight controller sees only this topic.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

import interfaces
from interfaces import graph
from runtime import Node, Time
from runtime.clock import seconds_to_ns
from runtime.parameters import param, validate_parameters
from sim.world import Scene

MAP_FRAME = "map"
_BLOCK = 256  # updates whose standard normals are drawn at once


@dataclass(frozen=True)
class VisionNoise:
    """Noise and drift of the visual odometry; :meth:`zero` gives the truth."""

    position_std: float = param(unit="m", range=(0.0, 1.0))
    """White noise of the position, per sample."""
    yaw_std: float = param(unit="rad", range=(0.0, 1.0))
    """White noise of the yaw, per sample."""
    drift_rate: float = param(unit="m/sqrt(s)", range=(0.0, 1.0))
    """Random-walk drift of the position."""
    latency_s: float = param(unit="s", range=(0.0, 1.0))
    """Processing delay before the pose is published."""

    def __post_init__(self) -> None:
        validate_parameters(self)

    @classmethod
    def zero(cls) -> VisionNoise:
        """No noise, no drift, no delay: the true pose."""
        return cls(position_std=0.0, yaw_std=0.0, drift_rate=0.0, latency_s=0.0)


@dataclass(frozen=True)
class VisionParams:
    """The simulated visual odometry (``config/sim_vision.yaml``)."""

    noise: VisionNoise
    rate_hz: float = param(unit="Hz", range=(1.0, 1000.0))
    """Poses per second (must divide the physics rate)."""


class VisionNode(Node):
    """Owns the vision topic's publisher and the measurement's parameters (the sim side)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("sim_vision", **kwargs)
        self.params = self.declare_params(VisionParams)
        pose = graph.SIM_VISION_POSE
        self.pose = self.create_publisher(pose.type, pose.name, pose.qos)
        self.stamp_offset_ns = 0
        """The stamps' clock minus simulated time [ns] (as
        :attr:`sim.sensors.SimSensorsNode.stamp_offset_ns`: a VIO on the vehicle's host
        stamps with the host's clock)."""


@dataclass
class VisionPose:
    """The world part that measures and publishes the pose (at ``rate_hz``, with ``noise``)."""

    node: VisionNode
    noise: VisionNoise
    rate_hz: float
    seed: int = 0
    name: str = "vision"
    tracking: bool = True
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """Added to every position [m, map] (a fault: the odometry jumped)."""
    extra_latency_s: float = 0.0
    """Added to the processing delay [s] (a fault: the odometry is late)."""
    published: int = 0

    def __post_init__(self) -> None:
        self._rng = np.random.default_rng(self.seed)
        self._drift = (0.0, 0.0, 0.0)
        self._normals: list[float] = []  # a block's normals, 7 an update, used from _next on
        self._next = 0

    @classmethod
    def from_node(cls, node: VisionNode, seed: int = 0,
                  noise: VisionNoise | None = None) -> VisionPose:
        """The part with the node's parameters (``noise`` replaces the node's noise)."""
        return cls(node, noise or node.params.noise, node.params.rate_hz, seed=seed)

    def update(self, t_ns: int, scene: Scene) -> None:
        n = self.noise
        # the 7 standard normals that rng.normal(0, std, 3) (drift step), rng.normal(0,
        # std, 3) (white noise) and rng.normal(0, std) (yaw) took, in their order, drawn
        # a block of updates at a time (the same sequence); each scaled as normal(loc,
        # std) scales, loc + std * z
        k = self._next
        if k == len(self._normals):
            self._normals = self._rng.standard_normal(_BLOCK * 7).tolist()
            k = 0
        zs = self._normals[k : k + 7]
        self._next = k + 7
        step = n.drift_rate * math.sqrt(1.0 / self.rate_hz)
        white, d = n.position_std, self._drift
        d = self._drift = (d[0] + (0.0 + step * zs[0]), d[1] + (0.0 + step * zs[1]),
                           d[2] + (0.0 + step * zs[2]))
        dyaw = 0.0 + n.yaw_std * zs[6]
        if not self.tracking:
            return
        px, py, pz, w, x, y, z = scene.views.quad_qpos.tolist()  # position, quaternion
        o = self.offset
        position = (px + d[0] + (0.0 + white * zs[3]) + o[0],
                    py + d[1] + (0.0 + white * zs[4]) + o[1],
                    pz + d[2] + (0.0 + white * zs[5]) + o[2])
        half = dyaw / 2.0  # yaw noise: rotate about world z
        cw, sz = math.cos(half), math.sin(half)
        q = (cw * w - sz * z, cw * x - sz * y, cw * y + sz * x, cw * z + sz * w)
        variance = n.position_std**2 + 1e-6
        cov = np.zeros(36)
        for i in range(3):
            cov[i * 7] = variance
        for i in range(3, 6):
            cov[i * 7] = n.yaw_std**2 + 1e-6
        msg = interfaces.new(
            "geometry_msgs/msg/PoseWithCovarianceStamped",
            header=interfaces.new("std_msgs/msg/Header",
                                  stamp=Time(t_ns + self.node.stamp_offset_ns).to_msg(),
                                  frame_id=MAP_FRAME),
            pose=interfaces.new(
                "geometry_msgs/msg/PoseWithCovariance",
                pose=interfaces.new(
                    "geometry_msgs/msg/Pose",
                    position=interfaces.new("geometry_msgs/msg/Point", x=position[0],
                                            y=position[1], z=position[2]),
                    orientation=interfaces.new("geometry_msgs/msg/Quaternion", x=q[1],
                                               y=q[2], z=q[3], w=q[0])),
                covariance=cov),
        )
        publish_at = t_ns + seconds_to_ns(n.latency_s + self.extra_latency_s)
        self.node.context.loop.call_at(publish_at, lambda: self.node.pose.publish(msg),
                                       (self.node.get_name(), "vision", graph.SIM_VISION_POSE.name))
        self.published += 1
