"""The DDS transport under the node API: topics, services, actions and QoS, on loopback.

Two transports in one process are two DDS participants: samples go through Cyclone
(serialised, over the loopback interface), never through shared objects.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import pytest
from cyclonedds.core import Policy

import interfaces
from interfaces.qos import QoSProfile, ReliabilityPolicy, qos_profile_default
from runtime import ActionClient, ActionServer, Node
from runtime.dds.config import DdsConfig
from runtime.processes.executor import ClockedExecutor
from runtime.dds.transport import DdsTransport

Spin = Callable[[Callable[[], bool], float], bool]


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


def test_topic_samples_cross_and_carry_the_type_hash(pair: Any) -> None:
    a, b, spin = pair
    talker, listener = Node("talker", context=a.context), Node("listener", context=b.context)
    pub = talker.create_publisher("std_msgs/msg/String", "/dds_test/chatter", qos_profile_default)
    heard: list[Any] = []
    sub = listener.create_subscription("std_msgs/msg/String", "/dds_test/chatter", heard.append,
                                       qos_profile_default)
    assert spin(lambda: pub.get_subscription_count() == 1 and sub.get_publisher_count() == 1)
    for i in range(3):
        pub.publish(interfaces.new("std_msgs/msg/String", data=f"hello {i}"))
    assert spin(lambda: len(heard) == 3)
    assert [m.data for m in heard] == ["hello 0", "hello 1", "hello 2"]
    reader = sub._reader.reader  # what the remote writer announced in discovery
    (handle,) = reader.get_matched_publications()
    endpoint = reader.get_matched_publication_data(handle)
    assert endpoint.topic_name == "rt/dds_test/chatter"
    assert endpoint.type_name == "std_msgs::msg::dds_::String_"
    assert endpoint.qos[Policy.Userdata].data == (
        b"typehash=RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18;")


def test_service_answers_the_caller_by_request_id(pair: Any) -> None:
    a, b, spin = pair
    server, caller = Node("server", context=a.context), Node("caller", context=b.context)

    def answer(request: Any, response: Any) -> Any:
        response.success = bool(request.force)
        response.message = f"timeout {request.timeout:g}"
        return response

    server.create_service("quadmission_interfaces/srv/Arm", "/dds_test/arm", answer)
    client = caller.create_client("quadmission_interfaces/srv/Arm", "/dds_test/arm")
    other = caller.create_client("quadmission_interfaces/srv/Arm", "/dds_test/arm")
    assert spin(lambda: client.service_is_ready() and other.service_is_ready())
    req = interfaces.new(client.srv_type.Request, force=True, timeout=1.5)
    first, second = client.call_async(req), other.call_async(
        interfaces.new(client.srv_type.Request, force=False, timeout=3.0))
    assert spin(lambda: first.done() and second.done())
    assert (first.result().success, first.result().message) == (True, "timeout 1.5")
    assert (second.result().success, second.result().message) == (False, "timeout 3")


def test_action_goal_feedback_and_result_cross(pair: Any) -> None:
    a, b, spin = pair
    server_node, client_node = Node("act_srv", context=a.context), Node("act_cli",
                                                                        context=b.context)

    async def execute(handle: Any) -> Any:
        handle.publish_feedback(interfaces.new(
            "quadmission_interfaces/action/Takeoff_Feedback", altitude=0.5))
        handle.succeed()
        return interfaces.new("quadmission_interfaces/action/Takeoff_Result", success=True,
                              message="up")

    ActionServer(server_node, "quadmission_interfaces/action/Takeoff", "/dds_test/takeoff",
                 execute)
    client = ActionClient(client_node, "quadmission_interfaces/action/Takeoff",
                          "/dds_test/takeoff")
    assert spin(client.server_is_ready)
    feedback: list[Any] = []
    sent = client.send_goal_async(
        interfaces.new("quadmission_interfaces/action/Takeoff_Goal", altitude=1.0),
        feedback_callback=feedback.append)
    assert spin(sent.done)
    result = sent.result().get_result_async()
    assert spin(result.done)
    assert result.result().result.message == "up"
    assert spin(lambda: len(feedback) == 1)


def test_incompatible_qos_is_reported_and_does_not_match(pair: Any) -> None:
    a, b, spin = pair
    fcu, companion = Node("fcu", context=a.context), Node("companion", context=b.context)
    best_effort = QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT)
    pub = fcu.create_publisher("std_msgs/msg/String", "/dds_test/px4_out", best_effort)
    sub = companion.create_subscription("std_msgs/msg/String", "/dds_test/px4_out",
                                        lambda _m: None, qos_profile_default)
    assert spin(lambda: bool(b.process_transport.incompatibilities) and bool(a.process_transport.incompatibilities))
    assert b.process_transport.incompatibilities[0].name == "/dds_test/px4_out"
    assert "RELIABILITY" in b.process_transport.incompatibilities[0].reason
    assert pub.get_subscription_count() == 0 and sub.get_publisher_count() == 0
