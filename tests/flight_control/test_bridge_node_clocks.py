"""The FCU bridge's clock conversion through its topics, with a chosen clock offset.

No simulator: a script plays the FCU side (``/fmu/out/timesync_status`` with the offset it
reports, then one ``/fmu/out/vehicle_odometry``), so the companion clock can be put ahead
of the FCU's or behind it. In both cases a sample's stamp on ``/fcu/odometry`` must be the
companion time at which the FCU took it, and a setpoint's ``/fmu/in`` stamp the FCU time at
which the companion sent it. The sample is taken ``AGE_NS`` before it is received, so the
bridge's clamp to the receive time cannot hide an offset that is dropped or applied with
the wrong sign.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pytest

import interfaces
from flight_control.bridge_node import FcuBridgeNode
from interfaces.px4.topics import (
    FCU_BRIDGE_ACK_QOS,
    FCU_BRIDGE_QOS,
    FMU_IN,
    FMU_OUT,
    XRCE_SESSION,
)
from runtime import (
    DeterministicExecutor,
    Node,
    Time,
    qos_profile_default,
    qos_profile_sensor_data,
)

START_S = 40.0  # companion time when the FCU reports its offset; later than any offset here
AGE_NS = 40_000_000  # the sample was taken 40 ms before the bridge receives it
NS_PER_US = 1000


@dataclass
class Loop:
    """The bridge between a scripted FCU side and a reader of ``/fcu/odometry``."""

    ex: DeterministicExecutor
    bridge: FcuBridgeNode
    fcu: Node
    fcu_publishers: dict[str, Any] = field(default_factory=dict)
    odometry: list[Any] = field(default_factory=list)
    acks: list[Any] = field(default_factory=list)
    setpoints: list[Any] = field(default_factory=list)

    def report_offset(self, companion_minus_fcu_us: int, round_trip_us: int = 800) -> None:
        """The FCU's TimesyncStatus: its ``estimated_offset`` is FCU minus companion."""
        topic = FMU_OUT["timesync_status"]
        self.fcu_publishers[topic.name].publish(interfaces.new(
            topic.type, estimated_offset=-companion_minus_fcu_us,
            observed_offset=-companion_minus_fcu_us, round_trip_time=round_trip_us))
        self.ex.spin_for(0.001)

    def odometry_sampled_at(self, fcu_us: int) -> int:
        """Send one VehicleOdometry taken at FCU time ``fcu_us``; the ``/fcu/odometry``
        stamp [ns] it came out with."""
        topic = FMU_OUT["vehicle_odometry"]
        before = len(self.odometry)
        self.fcu_publishers[topic.name].publish(interfaces.new(
            topic.type, timestamp=max(fcu_us, 0), timestamp_sample=fcu_us,
            q=np.array([1.0, 0.0, 0.0, 0.0], dtype=np.float32),
            position=np.array([1.0, 2.0, -3.0], dtype=np.float32)))
        self.ex.spin_for(0.001)
        assert len(self.odometry) == before + 1, "the bridge did not republish the sample"
        return int(Time.from_msg(self.odometry[-1].header.stamp).nanoseconds)


def _loop() -> Loop:
    ex = DeterministicExecutor()
    bridge = FcuBridgeNode(context=ex.context,
                           parameter_overrides={"timesync_source": "fcu_status"})
    fcu = Node("scripted_fcu_side", context=ex.context)
    loop = Loop(ex, bridge, fcu)
    for short in ("timesync_status", "vehicle_odometry"):
        topic = FMU_OUT[short]
        loop.fcu_publishers[topic.name] = fcu.create_publisher(topic.type, topic.name,
                                                               FCU_BRIDGE_QOS)
    ack = FMU_OUT["vehicle_command_ack"]
    loop.fcu_publishers[ack.name] = fcu.create_publisher(ack.type, ack.name, FCU_BRIDGE_ACK_QOS)
    reader = Node("reader", context=ex.context)
    reader.create_subscription("nav_msgs/msg/Odometry", "/fcu/odometry", loop.odometry.append,
                               qos_profile_sensor_data)
    reader.create_subscription("quadmission_interfaces/msg/FcuCommandAck", "/fcu/command_ack",
                               loop.acks.append, qos_profile_default)
    setpoint = FMU_IN["trajectory_setpoint"]
    fcu.create_subscription(setpoint.type, setpoint.name, loop.setpoints.append, FCU_BRIDGE_QOS)
    for node in (bridge, fcu, reader):
        ex.add_node(node)
    ex.spin_for(START_S)
    return loop


# companion ahead of the FCU (the FCU booted after the companion's clock started), and
# behind it (the FCU's uptime is larger, as with the simulator's boot offset)
OFFSETS_US = pytest.mark.parametrize(
    "companion_minus_fcu_us", [7_250_000, -25_300_000], ids=["companion_ahead", "companion_behind"])


@OFFSETS_US
def test_an_fcu_sample_time_is_stamped_on_the_companion_clock(
        companion_minus_fcu_us: int) -> None:
    loop = _loop()
    loop.report_offset(companion_minus_fcu_us)
    assert loop.bridge.synced
    taken = []
    for age_ns in (3 * AGE_NS, AGE_NS):
        taken_ns = loop.ex.now_ns() - age_ns  # companion time at which the FCU sampled
        fcu_us = taken_ns // NS_PER_US - companion_minus_fcu_us  # that instant on the FCU
        stamp_ns = loop.odometry_sampled_at(fcu_us)
        assert stamp_ns == taken_ns, (
            f"stamped {(stamp_ns - taken_ns) / 1e6:+.3f} ms from the sample time: the clock "
            f"offset of {companion_minus_fcu_us / 1e6:+.2f} s is not applied as companion = "
            "FCU + offset")
        taken.append(taken_ns)
    # /fcu/pose_at's history holds the samples at the same companion times
    assert loop.bridge.history.span == tuple(taken)


@OFFSETS_US
def test_an_fcu_event_time_is_stamped_on_the_companion_clock(
        companion_minus_fcu_us: int) -> None:
    """The other /fmu/out messages (acks here; IMU, battery, status alike) carry one time,
    ``timestamp``: converted the same way."""
    loop = _loop()
    loop.report_offset(companion_minus_fcu_us)
    sent_ns = loop.ex.now_ns() - AGE_NS
    topic = FMU_OUT["vehicle_command_ack"]
    loop.fcu_publishers[topic.name].publish(interfaces.new(
        topic.type, timestamp=sent_ns // NS_PER_US - companion_minus_fcu_us, command=400))
    loop.ex.spin_for(0.001)
    assert [int(a.command) for a in loop.acks] == [400]
    assert Time.from_msg(loop.acks[0].header.stamp).nanoseconds == sent_ns


@OFFSETS_US
def test_a_companion_time_is_sent_on_the_fcu_clock(companion_minus_fcu_us: int) -> None:
    loop = _loop()
    loop.report_offset(companion_minus_fcu_us)
    nan = interfaces.new("geometry_msgs/msg/Vector3", x=math.nan, y=math.nan, z=math.nan)
    pilot = Node("pilot", context=loop.ex.context)
    pub = pilot.create_publisher("quadmission_interfaces/msg/FcuSetpoint", "/fcu/setpoint",
                                 qos_profile_sensor_data)
    loop.ex.add_node(pilot)
    sent_ns = loop.ex.now_ns()
    pub.publish(interfaces.new(
        "quadmission_interfaces/msg/FcuSetpoint",
        position=interfaces.new("geometry_msgs/msg/Point", x=1.0, y=2.0, z=3.0),
        velocity=nan, acceleration=nan, yaw=0.0, yaw_rate=math.nan))
    loop.ex.spin_for(0.001)
    assert loop.setpoints, "no trajectory setpoint reached the FCU side"
    assert int(loop.setpoints[-1].timestamp) == sent_ns // NS_PER_US - companion_minus_fcu_us


def test_a_sample_stamped_after_its_arrival_is_stamped_at_the_arrival() -> None:
    """An offset estimate a little off can put a sample in the future of the companion;
    the stamp is then the receive time (a stamp never runs ahead of the clock)."""
    loop = _loop()
    offset_us = -25_300_000
    loop.report_offset(offset_us)
    now_ns = loop.ex.now_ns()
    ahead_fcu_us = (now_ns + 5_000_000) // NS_PER_US - offset_us  # 5 ms in the future
    assert loop.odometry_sampled_at(ahead_fcu_us) == now_ns


def test_before_the_fcu_reports_an_offset_the_stamp_is_the_receive_time() -> None:
    """Not synced yet (PX4's sync_stamp): the sample time is on an unknown clock."""
    loop = _loop()
    assert not loop.bridge.synced
    now_ns = loop.ex.now_ns()
    assert loop.odometry_sampled_at(now_ns // NS_PER_US - 2 * AGE_NS // NS_PER_US) == now_ns
    # a report without a measured round trip is not a sync either
    loop.report_offset(-25_300_000, round_trip_us=0)
    assert not loop.bridge.synced
    now_ns = loop.ex.now_ns()
    assert loop.odometry_sampled_at(now_ns // NS_PER_US + 25_300_000 - 10_000) == now_ns


def test_a_sample_without_a_time_is_stamped_at_its_arrival() -> None:
    """``timestamp_sample`` 0: the FCU did not say when; synced or not, the receive time."""
    loop = _loop()
    loop.report_offset(7_250_000)
    now_ns = loop.ex.now_ns()
    assert loop.odometry_sampled_at(0) == now_ns
    # the FCU clock's first microsecond is a time like any other (7.25 s on ours)
    assert loop.odometry_sampled_at(1) == (1 + 7_250_000) * NS_PER_US


def test_the_bridge_says_when_the_time_sync_converges(caplog: pytest.LogCaptureFixture) -> None:
    """Until then the visual odometry is held back: the log line says when it starts."""
    loop = _loop()
    with caplog.at_level(logging.INFO, logger="quadmission.fcu_bridge"):
        loop.report_offset(-25_300_000, round_trip_us=0)
        assert not [r for r in caplog.records if "time sync" in r.getMessage()]
        loop.report_offset(-25_300_000)
        loop.report_offset(-25_300_000)
    said = [r.getMessage() for r in caplog.records if "time sync" in r.getMessage()]
    assert len(said) == 1 and "converged: companion minus FCU clock -25300000 us" in said[0], said


def test_the_bridge_says_when_its_time_sync_restarts_after_the_offset_steps(
        caplog: pytest.LogCaptureFixture) -> None:
    """Our Kalman filter on the bridge's own exchanges: converged, then the FCU's clock
    steps 50 ms. The filter restarts (six gated exchanges in a row), the bridge warns once
    and says when it has converged again."""
    ex = DeterministicExecutor()
    bridge = FcuBridgeNode(context=ex.context)
    fcu = Node("scripted_fcu_side", context=ex.context)
    request, reply = XRCE_SESSION["request"], XRCE_SESSION["reply"]
    replies = fcu.create_publisher(reply.type, reply.name, FCU_BRIDGE_QOS)
    fcu_minus_companion_ns = [25_000_000_000]

    def answer(msg: Any) -> None:
        replies.publish(interfaces.new(reply.type, seq=msg.seq, ts1=msg.ts1,
                                       tc1=int(msg.ts1) + fcu_minus_companion_ns[0]))

    fcu.create_subscription(request.type, request.name, answer, FCU_BRIDGE_QOS)
    for node in (bridge, fcu):
        ex.add_node(node)
    with caplog.at_level(logging.INFO, logger="quadmission.fcu_bridge"):
        ex.spin_for(5.0)
        assert bridge.synced
        fcu_minus_companion_ns[0] += 50_000_000
        ex.spin_for(0.2)  # 10 exchanges: the 6th restarts, too few since to converge
        assert not bridge.synced
        ex.spin_for(5.0)
    said = [r.getMessage().split("] ", 2)[-1] for r in caplog.records
            if "time sync" in r.getMessage()]
    assert len(said) == 3, said
    assert said[0].startswith("time sync converged: companion minus FCU clock -25000000 us")
    assert said[1].startswith(
        "time sync restarted (restart 1): the clock offset stepped from -25000000 to "
        "-25050000 us")
    assert said[2].startswith("time sync converged: companion minus FCU clock -25050000 us")
    assert bridge.synced


def test_an_fcu_that_reboots_is_synced_again_on_its_new_clock(
        caplog: pytest.LogCaptureFixture) -> None:
    """PX4 rebooted (or its clock jumped): the offset it reports steps by seconds. The
    bridge restarts its time sync, says so, holds stamps on the receive time for one
    report, then stamps on the new clock. A small change (the FCU's own filter moving)
    is no restart."""
    loop = _loop()
    loop.report_offset(7_250_000)
    loop.report_offset(7_250_000 + 5_000)  # 5 ms: the FCU's estimate moving
    assert loop.bridge.synced and loop.bridge.timesync.estimate.resets == 0
    rebooted = 7_250_000 + 31_000_000  # back 31 s later, its boot clock from the start
    with caplog.at_level(logging.INFO):
        loop.report_offset(rebooted)
        assert not loop.bridge.synced
        assert "time sync restarted (restart 1): the clock offset stepped from 7255000 to " \
               f"{rebooted} us" in caplog.text
        loop.report_offset(rebooted)
    assert loop.bridge.synced and "time sync converged" in caplog.text
    taken_ns = loop.ex.now_ns() - AGE_NS
    assert loop.odometry_sampled_at(taken_ns // NS_PER_US - rebooted) == taken_ns
