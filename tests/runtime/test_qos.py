"""QoS as DDS honours it: history depth, durability for late joiners, compatibility."""

from __future__ import annotations

from typing import Any

import pytest

import interfaces
from runtime import (
    DeterministicExecutor,
    DurabilityPolicy,
    HistoryPolicy,
    Node,
    QoSProfile,
    ReliabilityPolicy,
    TopicTypeError,
    qos_profile_px4_out,
    qos_profile_px4_subscriber,
    qos_profile_sensor_data,
)
from runtime.transport import Endpoint

INT = "std_msgs/msg/Int32"
RELIABLE_TL = QoSProfile(depth=2, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def _int(v: int) -> Any:
    return interfaces.new(INT, data=v)


def _collect(node: Node, topic: str, qos: QoSProfile) -> tuple[list[int], Any]:
    got: list[int] = []
    sub = node.create_subscription(INT, topic, lambda m: got.append(m.data), qos)
    return got, sub


def test_keep_last_depth_drops_the_oldest(ex: DeterministicExecutor) -> None:
    node = Node("n", context=ex.context)
    pub = node.create_publisher(INT, "burst", 10)
    got, sub = _collect(node, "burst", QoSProfile(depth=3))
    for v in range(10):  # a burst before the executor gets to the subscriber
        pub.publish(_int(v))
    ex.spin_for(0.1)
    assert got == [7, 8, 9]
    assert sub.dropped == 7


def test_keep_all_keeps_every_sample(ex: DeterministicExecutor) -> None:
    node = Node("n", context=ex.context)
    pub = node.create_publisher(INT, "burst", 10)
    got, _ = _collect(node, "burst", QoSProfile(depth=1, history=HistoryPolicy.KEEP_ALL))
    for v in range(50):
        pub.publish(_int(v))
    ex.spin_for(0.1)
    assert got == list(range(50))


def test_transient_local_delivers_the_last_samples_to_a_late_joiner(
    ex: DeterministicExecutor,
) -> None:
    node = Node("n", context=ex.context)
    pub = node.create_publisher(INT, "latched", RELIABLE_TL)
    for v in range(5):
        pub.publish(_int(v))
    ex.spin_for(1.0)
    late_tl, _ = _collect(node, "latched", RELIABLE_TL)
    late_volatile, _ = _collect(node, "latched", QoSProfile(depth=10))
    ex.spin_for(0.1)
    assert late_tl == [3, 4]  # the writer keeps depth=2
    assert late_volatile == []
    pub.publish(_int(5))
    ex.spin_for(0.1)
    assert late_tl == [3, 4, 5] and late_volatile == [5]


@pytest.mark.parametrize(
    ("writer", "reader", "reason"),
    [
        (qos_profile_sensor_data, QoSProfile(), "RELIABLE"),
        (QoSProfile(), RELIABLE_TL, "TRANSIENT_LOCAL"),
    ],
)
def test_incompatible_qos_does_not_communicate(
    ex: DeterministicExecutor, writer: QoSProfile, reader: QoSProfile, reason: str
) -> None:
    node = Node("n", context=ex.context)
    pub = node.create_publisher(INT, "t", writer)
    got, sub = _collect(node, "t", reader)
    pub.publish(_int(1))
    ex.spin_for(0.1)
    assert got == []
    assert pub.get_subscription_count() == 0 and sub.get_publisher_count() == 0
    transport = ex.context.transport
    assert any(reason in i.reason for i in transport.incompatibilities)  # type: ignore[attr-defined]


def test_best_effort_reader_matches_a_reliable_writer(ex: DeterministicExecutor) -> None:
    node = Node("n", context=ex.context)
    pub = node.create_publisher(INT, "t", QoSProfile())
    got, _ = _collect(node, "t", qos_profile_sensor_data)
    pub.publish(_int(7))
    ex.spin_for(0.1)
    assert got == [7]


def test_px4_profiles_match_as_the_px4_guide_says(ex: DeterministicExecutor) -> None:
    fcu = Node("fcu", context=ex.context)
    companion = Node("companion", context=ex.context)
    pub = fcu.create_publisher(INT, "/fmu/out/x", qos_profile_px4_out)
    got, _ = _collect(companion, "/fmu/out/x", qos_profile_px4_subscriber)
    _, default_sub = _collect(companion, "/fmu/out/x", QoSProfile())  # ROS default: RELIABLE
    pub.publish(_int(1))
    ex.spin_for(0.1)
    assert got == [1]
    assert default_sub.get_publisher_count() == 0


def test_one_topic_one_type(ex: DeterministicExecutor) -> None:
    node = Node("n", context=ex.context)
    node.create_publisher(INT, "t", 10)
    with pytest.raises(TopicTypeError, match="std_msgs/msg/Int32"):
        node.create_subscription("std_msgs/msg/String", "t", lambda m: None, 10)


def test_publishing_the_wrong_type_or_a_malformed_message_is_an_error(
    ex: DeterministicExecutor,
) -> None:
    node = Node("n", context=ex.context)
    pub = node.create_publisher(INT, "t", 10)
    with pytest.raises(TopicTypeError, match="expected std_msgs/msg/Int32"):
        pub.publish(interfaces.new("std_msgs/msg/String", data="x"))
    with pytest.raises(interfaces.MessageError, match=r"std_msgs/msg/Int32\.data"):
        pub.publish(interfaces.new(INT, data=2**40))


def test_malformed_bytes_are_dropped_and_counted_not_fatal(ex: DeterministicExecutor) -> None:
    node = Node("n", context=ex.context)
    got, sub = _collect(node, "/t", QoSProfile())
    raw = ex.context.transport.create_writer(Endpoint("/t", INT, QoSProfile()))
    raw.write(b"\x00\x01\x00\x00\x01")  # truncated CDR
    raw.write(interfaces.serialize(_int(42)))
    ex.spin_for(0.1)
    assert got == [42]
    assert sub.malformed == 1


def test_a_profile_defaults_to_reliable_keep_last_and_rejects_a_zero_depth() -> None:
    profile = QoSProfile(depth=4)  # rclpy's defaults for what is not given
    assert profile.history is HistoryPolicy.KEEP_LAST
    assert profile.reliability is ReliabilityPolicy.RELIABLE
    assert profile.durability is DurabilityPolicy.VOLATILE
    with pytest.raises(ValueError, match="depth"):
        QoSProfile(depth=0)


def test_a_late_joiner_gets_nothing_from_an_incompatible_transient_local_writer(
    ex: DeterministicExecutor,
) -> None:
    """A BEST_EFFORT writer's kept samples never reach a RELIABLE late joiner (no match)."""
    node = Node("n", context=ex.context)
    best_effort_tl = QoSProfile(
        depth=5,
        reliability=ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL,
    )
    pub = node.create_publisher(INT, "latched", best_effort_tl)
    for v in range(3):
        pub.publish(_int(v))
    ex.spin_for(0.1)
    reliable_late, sub = _collect(node, "latched", RELIABLE_TL)
    best_effort_late, _ = _collect(node, "latched", best_effort_tl)
    ex.spin_for(0.1)
    assert reliable_late == []
    assert sub.get_publisher_count() == 0
    assert best_effort_late == [0, 1, 2]  # the compatible late joiner does get them


@pytest.mark.parametrize("writer_first", [True, False])
def test_an_incompatibility_is_recorded_whichever_side_comes_first(
    ex: DeterministicExecutor, writer_first: bool
) -> None:
    node = Node("n", context=ex.context)
    transport = ex.context.transport
    if writer_first:
        pub = node.create_publisher(INT, "t", qos_profile_sensor_data)
        got, _ = _collect(node, "t", QoSProfile())
    else:
        got, _ = _collect(node, "t", QoSProfile())
        pub = node.create_publisher(INT, "t", qos_profile_sensor_data)
    reasons = [i for i in transport.incompatibilities if i.name == "/t"]  # type: ignore[attr-defined]
    assert len(reasons) == 1 and "RELIABLE" in reasons[0].reason
    pub.publish(_int(1))
    ex.spin_for(0.1)
    assert got == []


def test_keep_all_transient_local_writer_replays_every_sample_to_a_late_joiner(
    ex: DeterministicExecutor,
) -> None:
    """KEEP_ALL on the writer: its history is not cut at ``depth``."""
    node = Node("n", context=ex.context)
    keep_all_tl = QoSProfile(
        depth=2, history=HistoryPolicy.KEEP_ALL, durability=DurabilityPolicy.TRANSIENT_LOCAL
    )
    pub = node.create_publisher(INT, "latched", keep_all_tl)
    for v in range(20):
        pub.publish(_int(v))
    ex.spin_for(0.1)
    late, _ = _collect(node, "latched", keep_all_tl)
    ex.spin_for(0.1)
    assert late == list(range(20))
