"""ground_station/recorder_node.py: every topic the nodes publish ends up in the bag."""

from __future__ import annotations

from pathlib import Path

import pytest
from rosbags.highlevel import AnyReader

import interfaces
from ground_station.bag import bag_info
from ground_station.recorder_node import BagRecorderNode
from ground_station.topic_tap import TopicTapError
from quadmission.examples import Listener, Talker
from runtime import DeterministicExecutor, Node, ParameterError, qos_profile_sensor_data


class _Odometry(Node):
    """A best-effort publisher that starts after the recorder: discovery must find it."""

    def __init__(self, **kwargs: object) -> None:
        super().__init__("odometry", **kwargs)  # type: ignore[arg-type]
        self.pub = self.create_publisher("nav_msgs/msg/Odometry", "/fcu/odometry",
                                         qos_profile_sensor_data)
        self.sent = 0
        self.create_timer(0.01, self._tick)

    def _tick(self) -> None:
        self.pub.publish(interfaces.new("nav_msgs/msg/Odometry"))
        self.sent += 1


def test_recorder_finds_topics_and_records_every_sample(tmp_path: Path) -> None:
    ex = DeterministicExecutor()
    talker = Talker(context=ex.context)
    listener = Listener(context=ex.context)
    recorder = BagRecorderNode(tmp_path / "bag", context=ex.context)
    for node in (talker, listener, recorder):
        ex.add_node(node)
    ex.spin_for(1.0)
    odometry = _Odometry(context=ex.context)  # a topic that appears later
    ex.spin_for(1.0)
    recorder.close()

    with AnyReader([tmp_path / "bag"], default_typestore=interfaces.typestore()) as reader:
        counts: dict[str, int] = {}
        for connection, _, raw in reader.messages():
            reader.deserialize(raw, connection.msgtype)
            counts[connection.topic] = counts.get(connection.topic, 0) + 1
    assert counts["/chatter"] == len(listener.heard)
    discovery_s = recorder.params.discovery_period_s
    # the odometry topic is found at the first discovery tick after it appears
    assert odometry.sent - round(discovery_s / 0.01) <= counts["/fcu/odometry"] <= odometry.sent


def test_include_chooses_the_topics_recorded(tmp_path: Path) -> None:
    ex = DeterministicExecutor()
    talker = Talker(context=ex.context)
    recorder = BagRecorderNode(tmp_path / "bag", context=ex.context,
                               parameter_overrides={"include": "/chatter"})
    ex.add_node(talker)
    ex.add_node(recorder)
    _Odometry(context=ex.context)  # found by discovery, not included
    ex.spin_for(1.0)
    recorder.close()
    with AnyReader([tmp_path / "bag"], default_typestore=interfaces.typestore()) as reader:
        texts = [reader.deserialize(raw, c.msgtype).data for c, _, raw in reader.messages()]
    assert texts == [f"hello {i}" for i in range(1, talker.count + 1)]


def test_a_pattern_that_is_not_a_regular_expression_is_named(tmp_path: Path) -> None:
    ex = DeterministicExecutor()
    with pytest.raises(TopicTapError, match=r"include '/\(': not a regular expression"):
        BagRecorderNode(tmp_path / "bag", context=ex.context,
                        parameter_overrides={"include": "/("})
    assert bag_info(tmp_path / "bag").indexed, "the refused recorder left its bag open"


def test_a_yaml_that_still_names_topics_is_refused_naming_the_key(tmp_path: Path) -> None:
    """``topics`` (topics named by hand, for a transport that could not list them) is gone:
    both transports list their topics, and ``include``/``exclude`` choose among them."""
    ex = DeterministicExecutor()
    recorder = BagRecorderNode(tmp_path / "bag", context=ex.context, parameter_overrides={
        "topics": ["/chatter std_msgs/msg/String"]})
    with pytest.raises(ParameterError, match="unknown parameter 'topics' for node bag_recorder"):
        ex.add_node(recorder)
    recorder.destroy_node()


def test_a_launched_recorder_writes_where_its_parameter_says(tmp_path: Path) -> None:
    from runtime import LaunchDescription, NodeSpec, launch

    ex = DeterministicExecutor()
    talker = Talker(context=ex.context)
    ex.add_node(talker)
    (recorder,) = launch(LaunchDescription((NodeSpec(
        "ground_station.recorder_node:BagRecorderNode",
        parameters={"folder": str(tmp_path / "launched")}),)), ex)
    ex.spin_for(1.0)
    recorder.destroy_node()
    assert bag_info(tmp_path / "launched").message_count == talker.count
