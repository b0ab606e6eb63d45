"""The companion side of seed 000's latency test (section 2.9, Algorithm 2), as a node.

:class:`LatencyTestNode` speaks only the px4 topics and the sensor topics, as a node on a
real companion computer would:

- **time sync**: a Timesync exchange over ``/xrce_session/timesync_request`` ->
  ``/xrce_session/timesync_reply``
  at ``timesync_hz``, half a stream period out of phase with the stream; every reply
  updates *each* estimator in ``estimators`` (by default ``"px4"`` and ``"kalman"``,
  :func:`~flight_control.timesync.make_estimator`), so they run side by side on the same
  exchanges. Each estimate is logged with the local time.
- **forward stream** (companion -> FCU): at ``rate_hz`` a ``VehicleOdometry`` on
  ``/fmu/in/vehicle_visual_odometry`` carrying the latest ``/sim/vision/pose`` (ENU/FLU
  turned into NED/FRD). ``timestamp`` is the creation time on the companion clock, raw
  (it doubles as the sample's key); ``timestamp_sample`` is that time on the FCU clock
  by the ``primary`` estimator, the stamp the FCU's estimator fuses at. The creation time
  converted by every estimator is logged in :attr:`LatencyTestNode.sent`, so the latency
  can be measured where the FCU consumes the sample, for each estimator.
- **reverse stream** (FCU -> companion): every ``/fmu/out/sensor_combined`` (stamped on
  the FCU clock at the IMU sample) is logged in :attr:`LatencyTestNode.received` with its
  receive time on the companion clock and its stamp converted by every estimator.

The node only logs; :mod:`flight_control.latency` turns the logs into figures. QoS as
seed 000 section 3.1: best effort, keep last, (transient local on the FCU's side).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from flight_control.px4_messages import vision_odometry
from flight_control.timesync import make_estimator
from interfaces import graph
from interfaces.px4.timesync import TimesyncEstimator, TimesyncExchange, ns_to_us
from interfaces.px4.topics import FMU_IN, FMU_OUT, LATENCY_TEST_PUBLISHER_QOS, XRCE_SESSION
from runtime import Node, qos_profile_px4_subscriber

TIMESYNC_MSG = "quadmission_interfaces/msg/Timesync"  # the modelled XRCE session sync

__all__ = ["LatencyTestNode"]



# -- the logs ---------------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class SentVision:
    """One forward sample as the companion created it."""

    created_us: int  # companion clock at creation (the message's ``timestamp``)
    fcu_stamp_us: Mapping[str, int]  # the creation time on the FCU clock, per estimator


@dataclass(frozen=True, slots=True)
class ReceivedImu:
    """One reverse sample as the companion received it."""

    stamp_us: int  # the message's ``timestamp`` (FCU clock)
    received_us: int  # companion clock at reception
    local_stamp_us: Mapping[str, int]  # the stamp on the companion clock, per estimator


@dataclass(frozen=True, slots=True)
class OffsetLog:
    """Each estimator's offset (companion - FCU) after one exchange, at local time ``t_us``."""

    t_us: int
    offset_us: Mapping[str, int]


class LatencyTestNode(Node):
    """Seed 000's latency-test node: two 200 Hz streams and the estimators, logged."""

    def __init__(
        self,
        *,
        rate_hz: float = 200.0,
        timesync_hz: float = 100.0,
        estimators: Sequence[str] = ("px4", "kalman"),
        primary: str = "kalman",
        **kwargs: Any,
    ) -> None:
        super().__init__("latency_test", **kwargs)
        if not rate_hz > 0 or not timesync_hz > 0:
            raise ValueError(f"rate_hz={rate_hz}, timesync_hz={timesync_hz}: must be > 0")
        if primary not in estimators:
            raise ValueError(f"primary={primary!r} is not one of estimators={list(estimators)}")
        self.primary = primary
        self.estimators: dict[str, TimesyncEstimator] = {
            name: make_estimator(name) for name in estimators}
        self.sent: dict[int, SentVision] = {}
        self.received: list[ReceivedImu] = []
        self.offsets: list[OffsetLog] = []
        self.converged_us: dict[str, int | None] = dict.fromkeys(self.estimators)
        self._pose: tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]] | None = None
        self.exchange = TimesyncExchange(*self.estimators.values())
        self.create_subscription(TIMESYNC_MSG, XRCE_SESSION["reply"].name,
                                 self._on_timesync, qos_profile_px4_subscriber)
        imu, pose, vision = (FMU_OUT["sensor_combined"], graph.SIM_VISION_POSE,
                             FMU_IN["vehicle_visual_odometry"])
        self.create_subscription(imu.type, imu.name, self._on_imu, qos_profile_px4_subscriber)
        self.create_subscription(pose.type, pose.name, self._on_pose, pose.subscriber_qos)
        self.vision_pub = self.create_publisher(vision.type, vision.name,
                                                LATENCY_TEST_PUBLISHER_QOS)
        self.timesync_pub = self.create_publisher(TIMESYNC_MSG, XRCE_SESSION["request"].name,
                                                  LATENCY_TEST_PUBLISHER_QOS)
        self.create_timer(1.0 / rate_hz, self._send_vision)
        # exchanges half a stream period after the vision samples, so that neither waits
        # behind the other on the serial line (it is FIFO) every time they coincide
        self._timesync_period_s = 1.0 / timesync_hz
        self._start_timer = self.create_timer(0.5 / rate_hz, self._start_timesync)

    def _now_us(self) -> int:
        return ns_to_us(self.now().nanoseconds)

    # -- time sync --------------------------------------------------------------------
    def _start_timesync(self) -> None:
        self._start_timer.cancel()
        self._send_timesync()
        self.create_timer(self._timesync_period_s, self._send_timesync)

    def _send_timesync(self) -> None:
        self.timesync_pub.publish(self.exchange.request(self.now().nanoseconds))

    def _on_timesync(self, msg: Any) -> None:
        replies = self.exchange.reply(msg, self.now().nanoseconds)
        if replies is None:
            return
        now_us = self._now_us()
        estimates = dict(zip(self.estimators, replies, strict=True))
        for name, estimate in estimates.items():
            if estimate.converged and self.converged_us[name] is None:
                self.converged_us[name] = now_us
        self.offsets.append(OffsetLog(now_us, {name: e.offset_us for name, e in estimates.items()}))

    # -- forward stream: vision to the FCU ----------------------------------------------
    def _on_pose(self, msg: Any) -> None:
        p, o = msg.pose.pose.position, msg.pose.pose.orientation
        self._pose = ((p.x, p.y, p.z), (o.w, o.x, o.y, o.z), tuple(msg.pose.covariance))

    def _send_vision(self) -> None:
        if self._pose is None:  # nothing to send until the first pose
            return
        created_us = self._now_us()
        stamps = {name: est.local_to_remote(created_us) for name, est in self.estimators.items()}
        self.sent[created_us] = SentVision(created_us, stamps)
        position, q, covariance = self._pose
        self.vision_pub.publish(vision_odometry(position, q, covariance, timestamp_us=created_us,
                                                timestamp_sample_us=stamps[self.primary]))

    # -- reverse stream: IMU from the FCU -----------------------------------------------
    def _on_imu(self, msg: Any) -> None:
        stamp_us = int(msg.timestamp)
        self.received.append(ReceivedImu(
            stamp_us, self._now_us(),
            {name: est.remote_to_local(stamp_us) for name, est in self.estimators.items()}))
