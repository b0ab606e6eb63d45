"""The time-synchronised FCU bridge: the only node that speaks px4_msgs.

Below it, the flight controller's world: ``/fmu/in/*`` and ``/fmu/out/*``, NED/FRD,
microseconds on the FCU clock. Above it, ours: ENU ``map`` and FLU ``base_link``
(REP 103), builtin Time on the companion clock. The bridge alone converts frames
(:mod:`flight_control.frames`) and clocks (:mod:`flight_control.timesync`, the
estimator chosen by parameter), so no other node knows PX4 is there:

- it runs the Timesync exchange with the FCU (``/xrce_session/timesync_request`` ->
  ``/xrce_session/timesync_reply``, the modelled XRCE-DDS session sync; not PX4 topics),
  or, with ``timesync_source: fcu_status``, takes the offset PX4 v1.17 itself reports in
  ``/fmu/out/timesync_status`` (``estimated_offset``), and publishes the filter's state
  on ``/fcu/timesync_status``;
- ``/fmu/out`` -> ``/fcu/odometry`` (nav_msgs/Odometry), ``/fcu/imu``, ``/fcu/battery``,
  ``/fcu/status`` (FcuStatus), ``/fcu/command_ack``, each stamped with the FCU's sample
  time converted to the companion clock;
- ``/fcu/setpoint`` -> OffboardControlMode heartbeat + TrajectorySetpoint,
  ``/fcu/command`` -> VehicleCommand, ``/fcu/vision`` -> vehicle_visual_odometry (its
  sample time kept), each stamped on the FCU clock;
- ``/fcu/pose_at`` answers "where was the vehicle at time t" from a bounded history.
"""

from __future__ import annotations

import copy
import math
from typing import Any

import numpy as np

import interfaces
from flight_control import fcu_messages
from flight_control.fcu_messages import all_finite, nan_to_num
from flight_control.params import BridgeParams
from flight_control.pose_history import PoseHistory, PoseSample
from flight_control.px4_messages import (
    odometry_enu,
    offboard_control_mode,
    trajectory_setpoint,
    vehicle_command,
    vision_odometry,
)
from flight_control.timesync import ReportedOffset, make_estimator
from interfaces import graph
from interfaces.px4 import FMU_IN, FMU_OUT, ArmingState
from interfaces.px4.timesync import TimesyncEstimator, TimesyncExchange, ns_to_us
from interfaces.px4.topics import (
    FCU_BRIDGE_ACK_QOS,
    FCU_BRIDGE_LAZY_QOS,
    FCU_BRIDGE_QOS,
    XRCE_SESSION,
)
from runtime import Node, Subscription, Time


class FcuBridgeNode(Node):
    """See the module docstring; parameters in ``config/fcu_bridge.yaml``."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("fcu_bridge", **kwargs)
        self.params = self.declare_params(BridgeParams)
        self.reported: ReportedOffset | None = None
        self.timesync: TimesyncEstimator
        if self.params.timesync_source == "fcu_status":
            self.reported = ReportedOffset()
            self.timesync = self.reported
        else:
            self.timesync = make_estimator(self.params.timesync_estimator)
        self.history = PoseHistory(round(self.params.pose_history_s * 1e9))
        self.exchange = TimesyncExchange(self.timesync)
        self._last_fcu_ns: int | None = None
        self._synced_offset_us = 0  # the offset while last converged, for the restart's log
        self._status = interfaces.new("quadmission_interfaces/msg/FcuStatus",
                                      battery_remaining=math.nan)
        px4_out = FCU_BRIDGE_QOS
        # companion side
        self.odometry_pub = self._publisher(graph.FCU_ODOMETRY)
        self.imu_pub = self._publisher(graph.FCU_IMU)
        self.battery_pub = self._publisher(graph.FCU_BATTERY)
        self.status_pub = self._publisher(graph.FCU_STATUS)
        self.ack_pub = self._publisher(graph.FCU_COMMAND_ACK)
        self.timesync_pub = self._publisher(graph.FCU_TIMESYNC_STATUS)
        for to_fcu, callback in ((graph.FCU_SETPOINT, self._on_setpoint),
                                 (graph.FCU_COMMAND, self._on_command),
                                 (graph.FCU_VISION, self._on_vision)):
            self.create_subscription(to_fcu.type, to_fcu.name, callback, to_fcu.subscriber_qos)
        self.create_service(graph.POSE_AT.type, graph.POSE_AT.name, self._pose_at)
        # FCU side
        self.mode_out = self._fmu_publisher("offboard_control_mode")
        self.setpoint_out = self._fmu_publisher("trajectory_setpoint")
        self.command_out = self._fmu_publisher("vehicle_command")
        self.vision_out = self._fmu_publisher("vehicle_visual_odometry")
        request, reply = XRCE_SESSION["request"], XRCE_SESSION["reply"]
        if self.reported is None:
            self.timesync_out = self.create_publisher(request.type, request.name, FCU_BRIDGE_QOS)
            self.create_subscription(reply.type, reply.name, self._on_timesync, px4_out)
            self.create_timer(1.0 / self.params.timesync_rate_hz, self._send_timesync)
        else:
            status = FMU_OUT["timesync_status"]
            self.create_subscription(status.type, status.name, self._on_timesync_status,
                                     px4_out)
        ack = FMU_OUT["vehicle_command_ack"]
        self.create_subscription(ack.type, ack.name, self._on_ack, FCU_BRIDGE_ACK_QOS)
        for short, handler in (
            ("vehicle_odometry", self._on_odometry),
            ("battery_status", self._on_battery),
            ("vehicle_status", self._on_vehicle_status),
            ("vehicle_land_detected", self._on_land_detected),
            ("failsafe_flags", self._on_failsafe_flags),
            ("vehicle_local_position", self._on_local_position),
        ):
            topic = FMU_OUT[short]
            self.create_subscription(topic.type, topic.name, handler, px4_out)
        self._imu_in: Subscription[Any] | None = None
        self._follow_imu_readers()
        self.create_timer(1.0 / self.params.status_rate_hz, self._publish_status)

    def _publisher(self, topic: graph.Topic) -> Any:
        return self.create_publisher(topic.type, topic.name, topic.qos)

    def _fmu_publisher(self, short: str) -> Any:
        topic = FMU_IN[short]
        return self.create_publisher(topic.type, topic.name, FCU_BRIDGE_QOS)

    # -- clocks ---------------------------------------------------------------------------
    @property
    def synced(self) -> bool:
        return self.timesync.estimate.converged

    def to_fcu_us(self, t_ns: int) -> int:
        """A companion time [ns] on the FCU clock [us]."""
        return self.timesync.local_to_remote(ns_to_us(t_ns))

    def to_companion_ns(self, fcu_us: int) -> int:
        """An FCU time [us] on the companion clock [ns]; before the filter has converged,
        the receive time (PX4's sync_stamp does the same)."""
        now_ns = self._last_fcu_ns = self.now().nanoseconds
        if not self.synced or fcu_us <= 0:
            return now_ns
        return min(self.timesync.remote_to_local(fcu_us) * 1000, now_ns)

    def _stamp(self, fcu_us: int) -> Any:
        return Time(self.to_companion_ns(fcu_us)).to_msg()

    def _send_timesync(self) -> None:
        now_ns = self.now().nanoseconds
        self.timesync_out.publish(self.exchange.request(now_ns, self.to_fcu_us(now_ns)))

    def _on_timesync(self, msg: Any) -> None:
        was_synced = self.synced
        estimates = self.exchange.reply(msg, self.now().nanoseconds)
        if estimates is None:  # not an answer to one of our requests
            return
        (est,) = estimates
        self._publish_estimate(est, was_synced)

    def _on_timesync_status(self, msg: Any) -> None:
        assert self.reported is not None
        was_synced = self.synced
        est = self.reported.report(int(msg.estimated_offset), int(msg.observed_offset),
                                   int(msg.round_trip_time))
        self._publish_estimate(est, was_synced)

    def _publish_estimate(self, est: Any, was_synced: bool) -> None:
        self._last_fcu_ns = self.now().nanoseconds
        if est.converged and not was_synced:  # stamps move from receive to sample time
            self.history = PoseHistory(self.history.span_ns)
            self.get_logger().info(
                f"time sync converged: companion minus FCU clock {est.offset_us} us, "
                f"{est.samples} samples; visual odometry forwarded")
        elif was_synced and not est.converged:
            self.get_logger().warning(
                f"time sync restarted (restart {est.resets}): the clock offset stepped from "
                f"{self._synced_offset_us} to {est.observed_offset_us} us; visual odometry "
                "held back until it converges again")
        if est.converged:
            self._synced_offset_us = est.offset_us
        if not self.timesync_pub.get_subscription_count():
            return  # diagnostics nobody reads are not built
        self.timesync_pub.publish(fcu_messages.timesync_diagnostics(est, self.now().to_msg()))

    # -- FCU -> companion -----------------------------------------------------------------
    def _on_odometry(self, msg: Any) -> None:
        stamp_ns = self.to_companion_ns(int(msg.timestamp_sample))
        odo = odometry_enu(msg)
        if all_finite(odo.position) and all_finite(odo.q):
            self.history.add(PoseSample(stamp_ns, np.array(odo.position), np.array(odo.q),
                                        nan_to_num(np.array(odo.velocity))))
        if self.odometry_pub.get_subscription_count():  # else only /fcu/pose_at reads it
            self.odometry_pub.publish(fcu_messages.odometry(odo, Time(stamp_ns).to_msg()))

    def _follow_imu_readers(self) -> None:
        """Read /fmu/out/sensor_combined only while /fcu/imu has readers (checked with the
        status, so within a status period of one joining): otherwise the FCU need not
        build 100 SensorCombined messages a second for nobody (it still accounts for
        their bytes on the serial line). A lazy subscription, as image_transport's."""
        wanted = self.imu_pub.get_subscription_count() > 0
        if wanted and self._imu_in is None:
            topic = FMU_OUT["sensor_combined"]
            # volatile: a sample the agent kept from an earlier reader would be stale
            self._imu_in = self.create_subscription(topic.type, topic.name, self._on_imu,
                                                    FCU_BRIDGE_LAZY_QOS)
        elif not wanted and self._imu_in is not None:
            self.destroy_subscription(self._imu_in)
            self._imu_in = None

    def _on_imu(self, msg: Any) -> None:
        self.imu_pub.publish(fcu_messages.imu(msg, self._stamp(int(msg.timestamp))))

    def _on_battery(self, msg: Any) -> None:
        self._status.battery_warning = int(msg.warning)
        self._status.battery_remaining = float(msg.remaining)
        self.battery_pub.publish(fcu_messages.battery(msg, self._stamp(int(msg.timestamp))))

    def _on_vehicle_status(self, msg: Any) -> None:
        s = self._status
        s.header = interfaces.new("std_msgs/msg/Header", stamp=self._stamp(int(msg.timestamp)))
        s.armed = int(msg.arming_state) == ArmingState.ARMED
        s.nav_state = int(msg.nav_state)
        s.offboard = s.nav_state == s.NAV_STATE_OFFBOARD
        s.failsafe = bool(msg.failsafe)
        s.pre_flight_checks_pass = bool(msg.pre_flight_checks_pass)
        self._publish_status()

    def _on_land_detected(self, msg: Any) -> None:
        self._status.landed = bool(msg.landed)

    def _on_failsafe_flags(self, msg: Any) -> None:
        self._status.offboard_signal_lost = bool(msg.offboard_control_signal_lost)

    def _on_local_position(self, msg: Any) -> None:
        self._status.position_valid = bool(msg.xy_valid and msg.z_valid)

    def _on_ack(self, msg: Any) -> None:
        self.ack_pub.publish(fcu_messages.command_ack(msg, self._stamp(int(msg.timestamp))))

    def _publish_status(self) -> None:
        self._follow_imu_readers()
        last = self._last_fcu_ns
        timeout_ns = self.params.connection_timeout_s * 1e9
        self._status.connected = last is not None and self.now().nanoseconds - last < timeout_ns
        # a snapshot: in one process subscribers share what is published, and the
        # handlers above keep updating self._status
        self.status_pub.publish(copy.copy(self._status))

    # -- companion -> FCU -----------------------------------------------------------------
    def _on_setpoint(self, msg: Any) -> None:
        stamp = self.to_fcu_us(self.now().nanoseconds)
        setpoint = trajectory_setpoint(
            [msg.position.x, msg.position.y, msg.position.z],
            [msg.velocity.x, msg.velocity.y, msg.velocity.z],
            [msg.acceleration.x, msg.acceleration.y, msg.acceleration.z],
            float(msg.yaw), float(msg.yaw_rate), timestamp_us=stamp)
        self.mode_out.publish(offboard_control_mode(setpoint, timestamp_us=stamp))
        self.setpoint_out.publish(setpoint)

    def _on_command(self, msg: Any) -> None:
        self.command_out.publish(vehicle_command(
            int(msg.command), [msg.param1, msg.param2, msg.param3, msg.param4, msg.param5,
                               msg.param6, msg.param7],
            timestamp_us=self.to_fcu_us(self.now().nanoseconds)))

    def _on_vision(self, msg: Any) -> None:
        if not self.synced:  # a sample time on the wrong clock would be fused at the
            return  # wrong time: wait for the time sync, as PX4's EKF2 would gate it
        p, o = msg.pose.pose.position, msg.pose.pose.orientation
        now_ns = self.now().nanoseconds
        self.vision_out.publish(vision_odometry(
            [p.x, p.y, p.z], [o.w, o.x, o.y, o.z], msg.pose.covariance,
            timestamp_us=self.to_fcu_us(now_ns),
            timestamp_sample_us=self.to_fcu_us(Time.from_msg(msg.header.stamp).nanoseconds)))

    def _pose_at(self, request: Any, response: Any) -> Any:
        t_ns = Time.from_msg(request.stamp).nanoseconds
        sample = self.history.at(t_ns)
        if sample is None:
            response.success = False
            response.message = self.history.missing(t_ns)
            return response
        response.success = True
        response.odometry = fcu_messages.pose_odometry(sample, request.stamp)
        return response
