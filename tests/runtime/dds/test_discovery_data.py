"""What only Cyclone DDS shows: the wire names, type names and type hash in discovery (the
transport tests, incompatible QoS named included, run on both transports)."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import pytest
from cyclonedds.core import Policy

import interfaces
from interfaces.qos import qos_profile_default
from runtime import Node
from runtime.dds.config import DdsConfig
from runtime.dds.transport import DdsTransport
from runtime.processes.executor import ClockedExecutor


@pytest.fixture
def pair(dds_config: DdsConfig) -> Any:
    a = ClockedExecutor(DdsTransport(dds_config), use_sim_time=False, config_dir=None)
    b = ClockedExecutor(DdsTransport(dds_config), use_sim_time=False, config_dir=None)

    def spin(until: Callable[[], bool], timeout_s: float = 10.0) -> bool:
        deadline = time.monotonic() + timeout_s
        while not until() and time.monotonic() < deadline:
            a.spin_once_realtime()
            b.spin_once_realtime()
        return until()

    yield a, b, spin
    a.process_transport.close()
    b.process_transport.close()


def test_topic_carries_ros2_names_and_the_type_hash(pair: Any) -> None:
    a, b, spin = pair
    talker, listener = Node("talker", context=a.context), Node("listener", context=b.context)
    pub = talker.create_publisher("std_msgs/msg/String", "/dds_test/chatter", qos_profile_default)
    sub = listener.create_subscription("std_msgs/msg/String", "/dds_test/chatter",
                                       lambda _m: None, qos_profile_default)
    assert spin(lambda: pub.get_subscription_count() == 1 and sub.get_publisher_count() == 1)
    reader = sub._reader.reader  # what the remote writer announced in discovery
    (handle,) = reader.get_matched_publications()
    endpoint = reader.get_matched_publication_data(handle)
    assert endpoint.topic_name == "rt/dds_test/chatter"
    assert endpoint.type_name == "std_msgs::msg::dds_::String_"
    assert endpoint.qos[Policy.Userdata].data == (
        b"typehash=RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18;")
    pub.publish(interfaces.new("std_msgs/msg/String", data="x"))
