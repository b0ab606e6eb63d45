"""The DDS types built from the typestore write exactly rosbags' CDR, under ROS 2's names."""

from __future__ import annotations

import struct

import numpy as np
import pytest

import interfaces
from runtime.dds.transport import frame_request, unframe_request
from runtime.dds.types import dds_topic_name, dds_type_name, idl_struct, type_hash
from runtime.transport import EndpointKind, RequestId

#: Every message of ours, and the ROS types our nodes send (strings, sequences, nested
#: arrays, bounded and fixed arrays, empty messages, 64-bit and 8-bit fields).
TYPES = sorted(
    {*interfaces.registered_types("px4_msgs"),
     *interfaces.registered_types("quadmission_interfaces"),
     "std_msgs/msg/String", "std_msgs/msg/Empty", "nav_msgs/msg/Odometry",
     "sensor_msgs/msg/Imu", "sensor_msgs/msg/Image", "sensor_msgs/msg/PointCloud2",
     "sensor_msgs/msg/CameraInfo", "sensor_msgs/msg/BatteryState",
     "action_msgs/msg/GoalStatusArray", "rosgraph_msgs/msg/Clock"})


def _filled(type_name: str, rng: np.random.Generator) -> object:
    """A message with every field set to a non-default value (so field order and
    alignment show in the bytes), built through the typestore's own definitions."""
    msg = interfaces.new(type_name)
    for info in interfaces.describe(type_name)[1]:
        value = getattr(msg, info.name)
        if isinstance(value, bool):
            setattr(msg, info.name, True)
        elif isinstance(value, int) and not isinstance(value, bool):
            setattr(msg, info.name, int(rng.integers(1, 100)))
        elif isinstance(value, float):
            setattr(msg, info.name, float(rng.normal()))
        elif isinstance(value, str):
            setattr(msg, info.name, "ab" * int(rng.integers(1, 5)))
        elif isinstance(value, np.ndarray) and value.size:
            setattr(msg, info.name, (rng.integers(1, 100, value.shape)).astype(value.dtype))
        elif isinstance(value, np.ndarray) and value.dtype == np.uint8:
            setattr(msg, info.name, rng.integers(0, 255, int(rng.integers(1, 9)),
                                                 dtype=np.uint8))
    return msg


@pytest.mark.parametrize("type_name", TYPES)
def test_idl_struct_bytes_equal_rosbags_cdr(type_name: str) -> None:
    rng = np.random.default_rng(len(type_name))
    for msg in (interfaces.new(type_name), _filled(type_name, rng)):
        ours = interfaces.serialize(msg, type_name)
        cls = idl_struct(type_name)
        sample = cls.deserialize(ours)
        assert sample.serialize(use_version_2=False) == ours, type_name


def test_idl_struct_is_final_and_named_as_ros2() -> None:
    cls = idl_struct("px4_msgs/msg/VehicleOdometry")
    assert cls.__idl_typename__ == "px4_msgs::msg::dds_::VehicleOdometry_"
    assert cls.__idl_annotations__["extensibility"] == "final"
    assert dds_type_name("quadmission_interfaces/srv/Arm_Request") == (
        "quadmission_interfaces::srv::dds_::Arm_Request_")


def test_topic_and_service_names_follow_ros2() -> None:
    assert dds_topic_name("/fcu/odometry", EndpointKind.TOPIC) == "rt/fcu/odometry"
    assert dds_topic_name("/flight_control/arm", EndpointKind.REQUEST) == (
        "rq/flight_control/armRequest")
    assert dds_topic_name("/flight_control/arm", EndpointKind.REPLY) == (
        "rr/flight_control/armReply")


def test_type_hash_is_rihs01_of_the_definition() -> None:
    # std_msgs/msg/String's hash as ROS 2 Jazzy publishes it.
    assert type_hash("std_msgs/msg/String") == (
        "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18")
    assert type_hash("px4_msgs/msg/VehicleStatus") != type_hash("px4_msgs/msg/VehicleOdometry")


def test_request_framing_is_rmw_cyclonedds_header_then_body() -> None:
    request = interfaces.new("quadmission_interfaces/srv/Arm_Request", force=True, timeout=2.5)
    body = interfaces.serialize(request)
    framed = frame_request(body, RequestId(0x0102030405060708, 42))
    assert framed[:4] == body[:4]
    assert struct.unpack_from("<Qq", framed, 4) == (0x0102030405060708, 42)
    assert framed[20:] == body[4:]
    # the framed bytes are the service type's wire struct: header fields, then the request
    wire = idl_struct("quadmission_interfaces/srv/Arm_Request", True).deserialize(framed)
    assert (wire.request_guid_, wire.request_seq_, wire.force, wire.timeout) == (
        0x0102030405060708, 42, True, 2.5)
    assert unframe_request(framed) == (body, RequestId(0x0102030405060708, 42))
