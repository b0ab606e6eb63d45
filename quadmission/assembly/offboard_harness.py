"""A minimal companion for flight-controller tests, speaking only the px4 topics.

The flight-control layer (``flight_control/``) is what the mission uses; this harness is
the smallest thing that can fly the FCU on its own, for the FCU's tests and the
``square`` scenario. It:

- runs the companion side of the Timesync exchange (``/xrce_session/timesync_request`` ->
  ``/xrce_session/timesync_reply``) with the PX4 filter, to stamp what it sends in FCU time;
- forwards ``/sim/vision/pose`` (ENU/FLU, companion clock) to
  ``/fmu/in/vehicle_visual_odometry`` (NED/FRD, FCU microseconds, sample time kept);
- streams the offboard heartbeat and a trajectory setpoint at ``rate_hz``, arms, enters
  offboard, flies a reference path (stop-and-go trapezoidal speed profile along a
  polyline, with velocity and acceleration feed-forward) and lands with NAV_LAND.

It records the reference it commanded, for evaluation.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from enum import Enum
from typing import Any

import numpy as np
import numpy.typing as npt

import interfaces
from flight_control.px4_messages import vehicle_command, vision_odometry
from flight_control.timesync import make_estimator
from interfaces import graph
from interfaces.px4 import (
    MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
    ArmingState,
    NavigationState,
    Px4CustomMainMode,
    VehicleCmd,
)
from interfaces.px4.timesync import TimesyncExchange, ns_to_us
from interfaces.px4.topics import COMPANION_PUBLISHER_QOS, FMU_IN, FMU_OUT, XRCE_SESSION
from runtime import Node, Time, qos_profile_px4_subscriber
from sim.fcu.firmware import FirmwareConfig
from sim.fcu.sitl import Sitl, build_sitl
from sim.world import WorldResult

TIMESYNC_MSG = "quadmission_interfaces/msg/Timesync"  # the modelled XRCE session sync

FloatArray = npt.NDArray[np.float64]


class HarnessPhase(Enum):
    WAIT_ESTIMATE = "wait_estimate"
    STREAM = "stream"
    ARMING = "arming"
    CLIMB = "climb"
    FLY = "fly"
    LAND = "land"
    DONE = "done"


@dataclass(frozen=True)
class PathProfile:
    """Stop-and-go motion along a polyline: each segment accelerates, cruises, brakes."""

    corners: FloatArray  # (N, 3) NED [m]
    speed: float = 0.8  # m/s, cruise
    accel: float = 0.6  # m/s^2

    def _segment(self, length: float) -> tuple[float, float, float]:
        """Ramp time, cruise time and peak speed of one segment."""
        t_ramp = self.speed / self.accel
        d_ramp = 0.5 * self.accel * t_ramp**2
        if 2 * d_ramp >= length:
            t_ramp = math.sqrt(length / self.accel)
            return t_ramp, 0.0, self.accel * t_ramp
        return t_ramp, (length - 2 * d_ramp) / self.speed, self.speed

    @property
    def duration(self) -> float:
        total = 0.0
        for a, b in zip(self.corners[:-1], self.corners[1:], strict=True):
            t_ramp, t_cruise, _ = self._segment(float(np.linalg.norm(b - a)))
            total += 2 * t_ramp + t_cruise
        return total

    def at(self, t: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Position, velocity and acceleration [NED] at ``t`` seconds into the path."""
        for a, b in zip(self.corners[:-1], self.corners[1:], strict=True):
            length = float(np.linalg.norm(b - a))
            t_ramp, t_cruise, v_peak = self._segment(length)
            t_seg = 2 * t_ramp + t_cruise
            if t <= t_seg:
                u = (b - a) / length
                if t < t_ramp:
                    s, v, acc = 0.5 * self.accel * t * t, self.accel * t, self.accel
                elif t < t_ramp + t_cruise:
                    s = 0.5 * self.accel * t_ramp**2 + v_peak * (t - t_ramp)
                    v, acc = v_peak, 0.0
                else:
                    tb = t_seg - t
                    s, v, acc = length - 0.5 * self.accel * tb * tb, self.accel * tb, -self.accel
                return a + s * u, v * u, acc * u
            t -= t_seg
        last = self.corners[-1]
        return last.copy(), np.zeros(3), np.zeros(3)


def _nan3() -> npt.NDArray[np.float32]:
    return np.full(3, math.nan, dtype=np.float32)


class OffboardHarness(Node):
    """Flies ``path`` (NED corners, metres, relative to the take-off point) in offboard."""

    def __init__(
        self,
        path: Sequence[Sequence[float]],
        *,
        altitude: float = 1.5,
        speed: float = 0.8,
        rate_hz: float = 20.0,
        stream_s: float = 1.5,
        climb_tolerance: float = 0.1,
        hover_s: float = 2.0,
        fly: bool = True,
        **kwargs: Any,
    ) -> None:
        super().__init__("offboard_harness", **kwargs)
        self.phase = HarnessPhase.WAIT_ESTIMATE
        self.phase_started_ns: dict[HarnessPhase, int] = {}  # when each phase began
        self.relative_path = np.asarray(path, dtype=np.float64).reshape(-1, 3)
        self.altitude = altitude
        self.speed = speed
        self.stream_s = stream_s
        self.climb_tolerance = climb_tolerance
        self.hover_s = hover_s
        self.fly = fly
        self.heartbeat = True  # set False to stop the offboard stream (failsafe tests)
        self.auto_land = True  # set False to stay airborne after the path (failsafe tests)
        self.timesync = make_estimator("kalman")
        self.exchange = TimesyncExchange(self.timesync)
        self.position_ned: FloatArray | None = None
        self.position_valid = False
        self.nav_state = -1
        self.armed = False
        self.acks: list[Any] = []
        self.reference: list[tuple[int, FloatArray]] = []  # (t_ns, NED position)
        self.profile: PathProfile | None = None
        self._phase_start_ns = 0
        self._hold: FloatArray | None = None
        self._land_sent = False
        self._reached_ns: int | None = None  # when the climb first reached its target
        out = qos_profile_px4_subscriber
        self.create_subscription("px4_msgs/msg/VehicleLocalPosition",
                                 FMU_OUT["vehicle_local_position"].name, self._on_position, out)
        self.create_subscription("px4_msgs/msg/VehicleStatus", FMU_OUT["vehicle_status"].name,
                                 self._on_status, out)
        ack = FMU_OUT["vehicle_command_ack"]
        self.create_subscription(ack.type, ack.name, self.acks.append, out)
        self.create_subscription(TIMESYNC_MSG, XRCE_SESSION["reply"].name, self._on_timesync,
                                 out)
        pose = graph.SIM_VISION_POSE
        self.create_subscription(pose.type, pose.name, self._on_vision, pose.subscriber_qos)
        self.mode_pub, self.setpoint_pub, self.command_pub, self.vision_pub = (
            self.create_publisher(FMU_IN[short].type, FMU_IN[short].name,
                                  COMPANION_PUBLISHER_QOS)
            for short in ("offboard_control_mode", "trajectory_setpoint", "vehicle_command",
                          "vehicle_visual_odometry"))
        self.timesync_pub = self.create_publisher(TIMESYNC_MSG, XRCE_SESSION["request"].name,
                                                  COMPANION_PUBLISHER_QOS)
        self.create_timer(0.02, self._send_timesync)  # 50 Hz: converged in ~2 s
        self.create_timer(1.0 / rate_hz, self._step)

    # -- time sync and vision -----------------------------------------------------------
    def fcu_time_us(self, t_ns: int) -> int:
        """A companion time on the FCU clock (the time-sync estimate)."""
        return self.timesync.local_to_remote(ns_to_us(t_ns))

    def _send_timesync(self) -> None:
        self.timesync_pub.publish(self.exchange.request(self.now().nanoseconds))

    def _on_timesync(self, msg: Any) -> None:
        self.exchange.reply(msg, self.now().nanoseconds)

    def _on_vision(self, msg: Any) -> None:
        if not self.timesync.estimate.converged:
            return
        p, o = msg.pose.pose.position, msg.pose.pose.orientation
        self.vision_pub.publish(vision_odometry(
            [p.x, p.y, p.z], [o.w, o.x, o.y, o.z], msg.pose.covariance,
            timestamp_us=self.fcu_time_us(self.now().nanoseconds),
            timestamp_sample_us=self.fcu_time_us(Time.from_msg(msg.header.stamp).nanoseconds)))

    # -- FCU state ----------------------------------------------------------------------
    def _on_position(self, msg: Any) -> None:
        self.position_ned = np.array([msg.x, msg.y, msg.z], dtype=np.float64)
        self.position_valid = bool(msg.xy_valid and msg.z_valid)

    def _on_status(self, msg: Any) -> None:
        self.nav_state = int(msg.nav_state)
        self.armed = int(msg.arming_state) == ArmingState.ARMED

    # -- the flight ---------------------------------------------------------------------
    def _request_offboard(self) -> None:
        self.command(VehicleCmd.DO_SET_MODE, param1=float(MAV_MODE_FLAG_CUSTOM_MODE_ENABLED),
                     param2=float(Px4CustomMainMode.OFFBOARD))

    def command(self, command: int, **params: float) -> None:
        """Send ``command`` with its ``param1``..``param7`` (0 when not given)."""
        values = [params.pop(f"param{i}", 0.0) for i in range(1, 8)]
        if params:
            raise TypeError(f"VehicleCommand has no {', '.join(sorted(params))}")
        self.command_pub.publish(vehicle_command(
            command, values, timestamp_us=self.fcu_time_us(self.now().nanoseconds)))

    def _enter(self, phase: HarnessPhase) -> None:
        self.phase = phase
        self._phase_start_ns = self.now().nanoseconds
        self.phase_started_ns[phase] = self._phase_start_ns
        self.get_logger().debug(f"harness: {phase.value}")

    def _elapsed(self) -> float:
        return (self.now().nanoseconds - self._phase_start_ns) / 1e9

    def _send_setpoint(self, position: FloatArray, velocity: FloatArray | None = None,
                       accel: FloatArray | None = None) -> None:
        now_ns = self.now().nanoseconds
        self.reference.append((now_ns, position.copy()))
        stamp = self.fcu_time_us(now_ns)
        self.setpoint_pub.publish(interfaces.new(
            "px4_msgs/msg/TrajectorySetpoint", timestamp=stamp,
            position=position.astype(np.float32),
            velocity=(velocity if velocity is not None else np.full(3, math.nan)).astype(
                np.float32),
            acceleration=(accel if accel is not None else np.full(3, math.nan)).astype(
                np.float32),
            jerk=_nan3(), yaw=0.0, yawspeed=math.nan))

    def _step(self) -> None:
        if self.heartbeat and self.phase not in (HarnessPhase.LAND, HarnessPhase.DONE):
            self.mode_pub.publish(interfaces.new(
                "px4_msgs/msg/OffboardControlMode",
                timestamp=self.fcu_time_us(self.now().nanoseconds), position=True))
        if self.phase is HarnessPhase.WAIT_ESTIMATE:
            if self.position_valid and self.position_ned is not None:
                self._hold = self.position_ned.copy()
                self._enter(HarnessPhase.STREAM)
            return
        assert self._hold is not None
        start = self._hold
        climb_to = start + np.array([0.0, 0.0, -self.altitude])
        if self.phase is HarnessPhase.STREAM:
            self._send_setpoint(climb_to)
            if self._elapsed() >= self.stream_s:
                self._request_offboard()
                self.command(VehicleCmd.COMPONENT_ARM_DISARM, param1=1.0)
                self._enter(HarnessPhase.ARMING)
        elif self.phase is HarnessPhase.ARMING:
            self._send_setpoint(climb_to)
            if self.armed and self.nav_state == NavigationState.OFFBOARD:
                self._enter(HarnessPhase.CLIMB)
            elif self._elapsed() > 2.0:  # ask again, as a flight-control layer would
                self._request_offboard()
                self.command(VehicleCmd.COMPONENT_ARM_DISARM, param1=1.0)
                self._phase_start_ns = self.now().nanoseconds
        elif self.phase is HarnessPhase.CLIMB:
            self._send_setpoint(climb_to)
            assert self.position_ned is not None
            close = np.linalg.norm(self.position_ned - climb_to) < self.climb_tolerance
            if close and self._reached_ns is None:
                self._reached_ns = self.now().nanoseconds
            held = self._reached_ns is not None and (
                self.now().nanoseconds - self._reached_ns) / 1e9 > self.hover_s
            if held:
                corners = np.vstack([climb_to, climb_to + self.relative_path])
                self.profile = PathProfile(corners, speed=self.speed)
                self._enter(HarnessPhase.FLY if self.fly else HarnessPhase.LAND)
        elif self.phase is HarnessPhase.FLY:
            assert self.profile is not None
            position, velocity, accel = self.profile.at(self._elapsed())
            self._send_setpoint(position, velocity, accel)
            if self._elapsed() > self.profile.duration + self.hover_s:
                self._enter(HarnessPhase.LAND)
        elif self.phase is HarnessPhase.LAND:
            if not self._land_sent and self.auto_land:
                self.command(VehicleCmd.NAV_LAND)
                self._land_sent = True
            if not self.armed and self._elapsed() > 1.0:
                self._enter(HarnessPhase.DONE)

    @property
    def done(self) -> bool:
        return self.phase is HarnessPhase.DONE


def hover_flight(duration_s: float = 10.0, *, seed: int = 0, offsets: str = "balanced",
                 altitude: float = 1.5) -> tuple[Sitl, WorldResult]:
    """Take off with the offboard harness and hover for ``duration_s`` (for reports)."""
    sitl = build_sitl(seed=seed, firmware=FirmwareConfig(offsets=offsets))
    harness = OffboardHarness([[0.0, 0.0, 0.0]], altitude=altitude, hover_s=duration_s,
                              fly=False, context=sitl.executor.context)
    sitl.executor.add_node(harness)
    return sitl, sitl.run(duration_s + 10.0)
