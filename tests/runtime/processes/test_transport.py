"""The process transport under the node API: topics, services, actions, QoS, parameters.

Two transports in one process are two participants (two rclpy contexts on ``ros2``):
samples go through DDS, serialised, never through shared objects. The same node API on the
in-process transport is tested in tests/runtime; here, what only the process transport has
too: rcl nodes in the ROS 2 graph that a plain rclpy program sees.
"""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

import interfaces
from interfaces.qos import QoSProfile, ReliabilityPolicy, qos_profile_default
from runtime import ActionClient, ActionServer, Node
from runtime.processes.executor import ClockedExecutor
from tests.runtime.processes.conftest import make_transport, needs_ros2

ROOT = Path(__file__).resolve().parents[3]
Spin = Callable[[Callable[[], bool], float], bool]


@pytest.fixture
def pair(transport_kind: str, domain_id: int) -> Any:
    a = ClockedExecutor(make_transport(transport_kind, domain_id, "proc_a"),
                        use_sim_time=False, config_dir=None)
    b = ClockedExecutor(make_transport(transport_kind, domain_id, "proc_b"),
                        use_sim_time=False, config_dir=None)

    def spin(until: Callable[[], bool], timeout_s: float = 30.0) -> bool:  # a loaded machine
        deadline = time.monotonic() + timeout_s
        while not until() and time.monotonic() < deadline:
            a.spin_once_realtime()
            b.spin_once_realtime()
        return until()

    yield a, b, spin
    a.process_transport.close()
    b.process_transport.close()


def test_topic_samples_cross_in_order(pair: Any) -> None:
    a, b, spin = pair
    talker = Node("talker", context=a.context, namespace="/tt")
    listener = Node("listener", context=b.context)
    pub = talker.create_publisher("std_msgs/msg/String", "chatter", qos_profile_default)
    heard: list[Any] = []
    sub = listener.create_subscription("std_msgs/msg/String", "/tt/chatter", heard.append,
                                       qos_profile_default)
    assert spin(lambda: pub.get_subscription_count() == 1 and sub.get_publisher_count() == 1)
    for i in range(3):
        pub.publish(interfaces.new("std_msgs/msg/String", data=f"hello {i}"))
    assert spin(lambda: len(heard) == 3)
    assert [m.data for m in heard] == ["hello 0", "hello 1", "hello 2"]


def test_a_destroyed_subscription_leaves_the_topic(pair: Any) -> None:
    """rclpy's destroy_subscription: the DDS reader goes, so a publisher that publishes
    (or renders) only for its subscribers sees none; subscribing again makes one, not two."""
    a, b, spin = pair
    talker = Node("talker", context=a.context)
    listener = Node("listener", context=b.context)
    pub = talker.create_publisher("std_msgs/msg/String", "/chatter", qos_profile_default)
    for _ in range(2):
        sub = listener.create_subscription("std_msgs/msg/String", "/chatter", list().append,
                                           qos_profile_default)
        assert spin(lambda: pub.get_subscription_count() == 1)
        assert listener.destroy_subscription(sub)
        assert spin(lambda: pub.get_subscription_count() == 0), pub.get_subscription_count()


def test_service_answers_the_caller_by_request_id(pair: Any) -> None:
    a, b, spin = pair
    server, caller = Node("server", context=a.context), Node("caller", context=b.context)

    def answer(request: Any, response: Any) -> Any:
        response.success = bool(request.force)
        response.message = f"timeout {request.timeout:g}"
        return response

    server.create_service("quadmission_interfaces/srv/Arm", "/tt/arm", answer)
    client = caller.create_client("quadmission_interfaces/srv/Arm", "/tt/arm")
    other = caller.create_client("quadmission_interfaces/srv/Arm", "/tt/arm")
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

    ActionServer(server_node, "quadmission_interfaces/action/Takeoff", "/tt/takeoff",
                 execute)
    client = ActionClient(client_node, "quadmission_interfaces/action/Takeoff",
                          "/tt/takeoff")
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


def test_incompatible_qos_does_not_match_and_is_named(pair: Any) -> None:
    a, b, spin = pair
    fcu, companion = Node("fcu", context=a.context), Node("companion", context=b.context)
    best_effort = QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT)
    pub = fcu.create_publisher("std_msgs/msg/String", "/tt/px4_out", best_effort)
    sub = companion.create_subscription("std_msgs/msg/String", "/tt/px4_out",
                                        lambda _m: None, qos_profile_default)
    compatible = companion.create_subscription("std_msgs/msg/String", "/tt/px4_out",
                                               lambda _m: None, best_effort)
    # discovery has happened, on both sides: each learns of the other on its own, and the
    # writer can hear of the reader after the reader has matched it (seen on a loaded machine)
    assert spin(lambda: compatible.get_publisher_count() == 1
                and pub.get_subscription_count() == 1)
    assert sub.get_publisher_count() == 0
    # and each side records the pair, naming the topic and the policy
    transport_a, transport_b = a.process_transport, b.process_transport
    assert spin(lambda: bool(transport_a.incompatibilities)
                and bool(transport_b.incompatibilities))
    (offered,), (requested,) = transport_a.incompatibilities, transport_b.incompatibilities
    assert offered.name == requested.name == "/tt/px4_out"
    assert offered.reason.startswith("offered ") and "RELIABILITY" in offered.reason
    assert requested.reason.startswith("requested ") and "RELIABILITY" in requested.reason


# -- our nodes are rcl nodes a plain rclpy program sees ---------------------------------------
@needs_ros2
def test_nodes_are_rcl_nodes_with_their_topics_types_and_qos(pair: Any) -> None:
    a, b, spin = pair
    talker = Node("talker", context=a.context, namespace="/tt")
    pub = talker.create_publisher("px4_msgs/msg/VehicleOdometry", "odometry",
                                  QoSProfile(depth=5,
                                             reliability=ReliabilityPolicy.BEST_EFFORT))
    observer = b.process_transport.rcl_node()  # rclpy's own graph API, from another context
    assert spin(lambda: ("talker", "/tt") in observer.get_node_names_and_namespaces()
                and bool(observer.get_publishers_info_by_topic("/tt/odometry")))
    (info,) = observer.get_publishers_info_by_topic("/tt/odometry")
    assert (info.node_name, info.node_namespace) == ("talker", "/tt")
    assert info.topic_type == "px4_msgs/msg/VehicleOdometry"
    # discovery carries reliability and durability (a depth stays with its endpoint)
    assert info.qos_profile.reliability.name == "BEST_EFFORT"
    assert info.qos_profile.durability.name == "VOLATILE"
    assert pub.get_subscription_count() == 0


@needs_ros2
def test_a_plain_rclpy_parameter_client_lists_reads_and_sets_them(pair: Any,
                                                                  domain_id: int) -> None:
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter as RclParameter
    from rclpy.parameter_client import AsyncParameterClient

    from runtime.parameters import ParameterDescriptor

    a, _b, spin = pair
    node = Node("tuned", context=a.context)
    node.declare_parameter("gain", 0.5, ParameterDescriptor(range=(0.0, 1.0)))
    node.declare_parameter("names", ("x", "y"))
    a.process_transport.mirror_parameters(node)
    context = Context()  # a foreign rclpy program: its own context, rclpy's executor
    rclpy.init(context=context, domain_id=domain_id)
    try:
        foreign = rclpy.create_node("param_tool", context=context)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(foreign)
        client = AsyncParameterClient(foreign, "/tuned")

        def call(future: Any) -> Any:
            deadline = time.monotonic() + 10.0
            while not future.done() and time.monotonic() < deadline:
                executor.spin_once(timeout_sec=0.005)
                a.spin_once_realtime()
            assert future.done(), "no answer from /tuned's parameter services"
            return future.result()

        assert spin(lambda: client.services_are_ready())
        names = call(client.list_parameters()).result.names
        assert {"gain", "names", "use_sim_time"} <= set(names)
        values = call(client.get_parameters(["gain", "names"])).values
        assert values[0].double_value == 0.5 and list(values[1].string_array_value) == ["x", "y"]
        (refused,) = call(client.set_parameters(
            [RclParameter("gain", RclParameter.Type.DOUBLE, 2.0)])).results
        assert not refused.successful and "range" in refused.reason
        (taken,) = call(client.set_parameters(
            [RclParameter("gain", RclParameter.Type.DOUBLE, 0.25)])).results
        assert taken.successful
        assert node.get_parameter("gain").value == 0.25  # our node holds the value
        foreign.destroy_node()
    finally:
        rclpy.shutdown(context=context)


@needs_ros2
def test_camera_images_cross_processes_best_effort_without_loss(domain_id: int) -> None:
    # A 640x480 RGB image is 921,600 B. In Fast DDS's default 512 KiB shared-memory
    # segments the writer recycled an image's fragments before the reader took them, and
    # images were lost whole (the mission's scanner then saw none for a second); our
    # participant profile's 16 MiB segments keep them. Five (the reader's depth) back to
    # back from another process, as a busy scanner meets them.
    sent = 5
    ex = ClockedExecutor(make_transport("ros2", domain_id, "scanner_process"),
                         use_sim_time=False, config_dir=None)
    scanner = Node("scanner", context=ex.context)
    frames: list[int] = []
    scanner.create_subscription("sensor_msgs/msg/Image", "/tt/image_raw",
                                lambda m: frames.append(m.header.stamp.sec),
                                QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT))
    camera = subprocess.Popen([sys.executable, "-m", "tests.runtime.processes.image_publisher",
                               str(domain_id), str(sent)], cwd=ROOT)
    try:
        deadline = time.monotonic() + 60.0
        while camera.poll() is None and len(frames) < sent and time.monotonic() < deadline:
            ex.spin_once_realtime()
    finally:
        ex.process_transport.close()
        camera.kill()
        camera.wait()
    assert frames == list(range(sent)), f"{len(frames)} of {sent} images arrived: {frames}"
