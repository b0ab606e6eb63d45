"""interfaces.api: type look-up, defaults, validation with field paths, CDR errors, and
the ROS 2 shape of composed action types; plus the conventions quadmission_interfaces
promises its users (success/message in results, units on physical fields)."""

from __future__ import annotations

import re
from typing import Any

import numpy as np
import pytest
from rosbags.interfaces import Nodetype

import interfaces
from interfaces import InterfaceError, MessageError, UnknownTypeError
from interfaces.registry import INTERFACE_ROOT, iter_interface_files

TIMESYNC_MSG = "quadmission_interfaces/msg/Timesync"  # the modelled XRCE session sync

QM = "quadmission_interfaces"
ACTIONS = sorted(f.name for f in iter_interface_files() if f.package == QM and f.kind == "action")
SERVICES = sorted(f.name for f in iter_interface_files() if f.package == QM and f.kind == "srv")


def fields_of(typename: str) -> list[tuple[str, Any]]:
    return list(interfaces.typestore().fielddefs[typename][1])


def field_map(typename: str) -> dict[str, Any]:
    return dict(fields_of(typename))


# --- look-up -------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("short", "full"),
    [
        ("px4_msgs/VehicleOdometry", "px4_msgs/msg/VehicleOdometry"),
        (f"{QM}/MissionState", f"{QM}/msg/MissionState"),
        ("std_msgs/Header", "std_msgs/msg/Header"),
    ],
)
def test_get_message_accepts_short_and_full_names(short: str, full: str) -> None:
    cls = interfaces.get_message(short)
    assert cls is interfaces.get_message(full)
    assert cls.__msgtype__ == full
    assert interfaces.type_name(cls) == full
    assert interfaces.type_name(interfaces.new(short)) == full


def test_get_service_accepts_short_and_full_names() -> None:
    svc = interfaces.get_service(f"{QM}/Arm")
    assert svc == interfaces.get_service(f"{QM}/srv/Arm")
    assert svc.name == f"{QM}/srv/Arm"
    assert svc.Request.__msgtype__ == f"{QM}/srv/Arm_Request"
    assert svc.Response.__msgtype__ == f"{QM}/srv/Arm_Response"


def test_get_action_accepts_short_and_full_names() -> None:
    act = interfaces.get_action(f"{QM}/Reach")
    assert act == interfaces.get_action(f"{QM}/action/Reach")
    assert act.name == f"{QM}/action/Reach"
    assert act.Goal.__msgtype__ == f"{QM}/action/Reach_Goal"
    assert act.Result.__msgtype__ == f"{QM}/action/Reach_Result"
    assert act.Feedback.__msgtype__ == f"{QM}/action/Reach_Feedback"


@pytest.mark.parametrize(
    ("getter", "name"),
    [
        (interfaces.get_message, "px4_msgs/NoSuchMessage"),
        (interfaces.get_message, "nosuchpkg/msg/Thing"),
        (interfaces.get_message, f"{QM}/Arm"),  # a service is not a message
        (interfaces.get_service, f"{QM}/NoSuchService"),
        (interfaces.get_service, f"{QM}/MissionState"),  # a message is not a service
        (interfaces.get_action, f"{QM}/NoSuchAction"),
        (interfaces.get_action, f"{QM}/Arm"),  # a service is not an action
    ],
)
def test_unknown_names_raise_unknown_type_error(getter: Any, name: str) -> None:
    with pytest.raises(UnknownTypeError) as info:
        getter(name)
    assert name in str(info.value)
    assert isinstance(info.value, InterfaceError)
    assert isinstance(info.value, KeyError)


@pytest.mark.parametrize(
    ("name", "parts"),
    [
        ("px4_msgs/msg/VehicleOdometry", [("message", "px4_msgs/msg/VehicleOdometry")]),
        (f"{QM}/MissionState", [("message", f"{QM}/msg/MissionState")]),
        (f"{QM}/srv/PlanPath", [("request", f"{QM}/srv/PlanPath_Request"),
                                ("response", f"{QM}/srv/PlanPath_Response")]),
        (f"{QM}/Arm", [("request", f"{QM}/srv/Arm_Request"),
                       ("response", f"{QM}/srv/Arm_Response")]),
        (f"/{QM}/action/Reach", [("goal", f"{QM}/action/Reach_Goal"),
                                 ("result", f"{QM}/action/Reach_Result"),
                                 ("feedback", f"{QM}/action/Reach_Feedback")]),
        (f"{QM}/Navigate", [("goal", f"{QM}/action/Navigate_Goal"),
                            ("result", f"{QM}/action/Navigate_Result"),
                            ("feedback", f"{QM}/action/Navigate_Feedback")]),
    ],
)
def test_interface_parts_of_a_message_a_service_and_an_action(
    name: str, parts: list[tuple[str, str]]
) -> None:
    assert interfaces.interface_parts(name) == parts


@pytest.mark.parametrize(
    ("name", "error"),
    [
        (f"{QM}/action/Arm", "unknown action type"),  # a service is not an action
        (f"{QM}/srv/Reach", "unknown service type"),
        (f"{QM}/msg/Reach", "unknown message type"),
        (f"{QM}/NoSuchThing", "unknown message, service or action type"),
        (f"{QM}/thing/Reach", "unknown message, service or action type"),
        ("Reach", "unknown message, service or action type"),
    ],
)
def test_interface_parts_rejects_unknown_names_naming_them(name: str, error: str) -> None:
    with pytest.raises(UnknownTypeError, match=f"{error} '{re.escape(name)}'"):
        interfaces.interface_parts(name)


def test_new_and_deserialize_reject_unknown_type_names() -> None:
    with pytest.raises(UnknownTypeError, match="NoSuch"):
        interfaces.new("px4_msgs/NoSuch")
    with pytest.raises(UnknownTypeError, match="NoSuch"):
        interfaces.deserialize(b"\x00\x01\x00\x00", "px4_msgs/NoSuch")


def test_type_name_rejects_non_messages() -> None:
    with pytest.raises(MessageError, match="not a message"):
        interfaces.type_name(42)


def test_registered_types_filters_by_package() -> None:
    px4 = interfaces.registered_types("px4_msgs")
    assert "px4_msgs/msg/VehicleCommand" in px4
    assert all(n.startswith("px4_msgs/") for n in px4)
    everything = interfaces.registered_types()
    assert set(px4) < set(everything)
    assert everything == sorted(everything)
    assert "sensor_msgs/msg/Image" in everything


# --- new(): defaults ---------------------------------------------------------------


def test_new_fills_ros_defaults() -> None:
    msg = interfaces.new("px4_msgs/VehicleOdometry")
    assert msg.timestamp == 0 and isinstance(msg.timestamp, int)
    assert msg.pose_frame == 0
    assert msg.quality == 0
    for name, length in [("position", 3), ("q", 4), ("velocity_variance", 3)]:
        arr = getattr(msg, name)
        assert isinstance(arr, np.ndarray), name
        assert arr.dtype == np.float32 and arr.shape == (length,), name
        assert not arr.any(), name
    interfaces.validate(msg)


def test_new_fills_nested_messages_strings_bools_and_sequences() -> None:
    msg = interfaces.new(f"{QM}/MissionEvent")
    assert interfaces.type_name(msg.header) == "std_msgs/msg/Header"
    assert msg.header.frame_id == ""
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (0, 0)
    assert msg.message == ""
    assert msg.values == []
    state = interfaces.new(f"{QM}/MissionState")
    assert isinstance(state.landing_sequence, np.ndarray)
    assert state.landing_sequence.dtype == np.uint16 and state.landing_sequence.size == 0
    assert interfaces.new("px4_msgs/OffboardControlMode").position is False
    interfaces.validate(msg)
    interfaces.validate(state)


def test_new_gives_independent_defaults() -> None:
    a = interfaces.new(f"{QM}/MarkerDetection")
    b = interfaces.new(f"{QM}/MarkerDetection")
    a.corners_px[0] = 5.0
    a.pose.position.x = 1.0
    a.header.frame_id = "cam"
    assert b.corners_px[0] == 0.0
    assert b.pose.position.x == 0.0
    assert b.header.frame_id == ""


def test_new_accepts_a_class_and_converts_lists_to_typed_arrays() -> None:
    cls = interfaces.get_message("px4_msgs/TrajectorySetpoint")
    msg = interfaces.new(cls, position=[1, 2, -3.5], yaw=0.25)
    assert isinstance(msg, cls)
    assert msg.position.dtype == np.float32
    np.testing.assert_array_equal(msg.position, [1.0, 2.0, -3.5])
    seq = interfaces.new(f"{QM}/LandingSequence", pad_ids=(3, 1, 7))
    assert seq.pad_ids.dtype == np.uint16
    assert seq.pad_ids.tolist() == [3, 1, 7]


def test_new_rejects_an_unknown_field_naming_it() -> None:
    with pytest.raises(MessageError) as info:
        interfaces.new("px4_msgs/VehicleCommand", comand=400)
    text = str(info.value)
    assert "'comand'" in text
    assert "px4_msgs/msg/VehicleCommand" in text
    assert "command" in text  # the valid fields are listed


@pytest.mark.parametrize(
    ("type_name", "kwargs", "path", "what"),
    [
        ("std_msgs/msg/UInt8MultiArray", {"data": [300] * 4}, "UInt8MultiArray.data[0]",
         "range"),
        ("std_msgs/msg/UInt8MultiArray", {"data": [1.5] * 4}, "UInt8MultiArray.data[0]",
         "integer"),
        ("px4_msgs/BatteryStatus", {"voltage_cell_v": [1.0] * 13 + ["x"]},
         "BatteryStatus.voltage_cell_v[13]", "number"),
    ],
)
def test_new_rejects_bad_list_elements_naming_them(
    type_name: str, kwargs: dict[str, Any], path: str, what: str
) -> None:
    # A float must not be truncated into an integer array, nor overflow wrap around.
    with pytest.raises(MessageError) as info:
        interfaces.new(type_name, **kwargs)
    assert path in str(info.value)
    assert what in str(info.value)


# --- validate() / serialize(): errors name the field --------------------------------


def _bad(typename: str, **fields: Any) -> Any:
    msg = interfaces.new(typename)
    for name, value in fields.items():
        setattr(msg, name, value)
    return msg


BAD_MESSAGES = [
    # out-of-range integers, at both ends and for every width that matters
    (_bad("px4_msgs/VehicleStatus", nav_state=256), "VehicleStatus.nav_state", "range"),
    (_bad("px4_msgs/VehicleStatus", nav_state=-1), "VehicleStatus.nav_state", "range"),
    (_bad("px4_msgs/VehicleOdometry", quality=-129), "VehicleOdometry.quality", "range"),
    (_bad("px4_msgs/VehicleOdometry", timestamp=2**64), "VehicleOdometry.timestamp", "range"),
    (_bad("px4_msgs/VehicleOdometry", timestamp=-1), "VehicleOdometry.timestamp", "range"),
    (_bad(TIMESYNC_MSG, tc1=2**63), "Timesync.tc1", "range"),
    (_bad("px4_msgs/VehicleCommand", command=2**32), "VehicleCommand.command", "range"),
    # wrong fixed-array length
    (
        _bad("px4_msgs/VehicleOdometry", q=np.zeros(3, np.float32)),
        "VehicleOdometry.q",
        "4 elements",
    ),
    (
        _bad("px4_msgs/BatteryStatus", voltage_cell_v=np.zeros(15, np.float32)),
        "BatteryStatus.voltage_cell_v",
        "14 elements",
    ),
    # wrong dtype or shape
    (_bad("px4_msgs/VehicleOdometry", q=np.zeros(4, np.float64)), "VehicleOdometry.q", "float32"),
    (
        _bad("px4_msgs/VehicleOdometry", q=np.zeros((4, 1), np.float32)),
        "VehicleOdometry.q",
        "1-D",
    ),
    (
        _bad(f"{QM}/LandingSequence", pad_ids=np.array([1, 2], np.int64)),
        "LandingSequence.pad_ids",
        "uint16",
    ),
    # wrong Python type
    (_bad("px4_msgs/VehicleOdometry", timestamp=1.0), "VehicleOdometry.timestamp", "integer"),
    (_bad("px4_msgs/VehicleOdometry", timestamp=True), "VehicleOdometry.timestamp", "integer"),
    (_bad("px4_msgs/OffboardControlMode", position=1), "OffboardControlMode.position", "bool"),
    (_bad("px4_msgs/TrajectorySetpoint", yaw="0.5"), "TrajectorySetpoint.yaw", "number"),
    (_bad("px4_msgs/TrajectorySetpoint", yaw=1e39), "TrajectorySetpoint.yaw", "float32"),
    (_bad(f"{QM}/MissionEvent", message=3), "MissionEvent.message", "string"),
    # a bounded string (string<=255), too long and of the wrong type
    (
        _bad("type_description_interfaces/FieldType", nested_type_name="x" * 256),
        "FieldType.nested_type_name",
        "bound 255",
    ),
    (
        _bad("type_description_interfaces/FieldType", nested_type_name=7),
        "FieldType.nested_type_name",
        "string",
    ),
    (_bad("px4_msgs/VehicleOdometry", q=5), "VehicleOdometry.q", "array"),
    (
        _bad(f"{QM}/MissionEvent", header=interfaces.new("builtin_interfaces/Time")),
        "MissionEvent.header",
        "std_msgs/msg/Header",
    ),
]


@pytest.mark.parametrize(("msg", "path", "what"), BAD_MESSAGES)
def test_validate_and_serialize_reject_bad_values_naming_the_field(
    msg: Any, path: str, what: str
) -> None:
    for check in (interfaces.validate, interfaces.serialize):
        with pytest.raises(MessageError) as info:
            check(msg)
        assert path in str(info.value), f"{check.__name__}: {info.value}"
        assert what in str(info.value), f"{check.__name__}: {info.value}"


def test_errors_give_the_full_path_into_nested_sequences() -> None:
    det = [interfaces.new(f"{QM}/MarkerDetection") for _ in range(3)]
    msg = interfaces.new(f"{QM}/MarkerDetectionArray", detections=det)
    interfaces.validate(msg)
    msg.detections[2].pose.position.x = "far"
    with pytest.raises(MessageError, match=re.escape("detections[2].pose.position.x")):
        interfaces.serialize(msg)
    msg.detections[2].pose.position.x = 1.0
    msg.detections[1] = interfaces.new("std_msgs/Header")
    with pytest.raises(MessageError, match=re.escape("detections[1]: expected a")):
        interfaces.validate(msg)


def test_integer_limits_and_special_floats_are_accepted() -> None:
    msg = interfaces.new(
        "px4_msgs/VehicleLocalPosition",
        timestamp=2**64 - 1,
        xy_reset_counter=255,
        vxy_max=float("inf"),  # PX4: INFINITY when no limit is required
        x=float("nan"),  # PX4: NaN when invalid
    )
    back = interfaces.deserialize(interfaces.serialize(msg), "px4_msgs/VehicleLocalPosition")
    assert back.timestamp == 2**64 - 1
    assert back.xy_reset_counter == 255
    assert back.vxy_max == float("inf")
    assert np.isnan(back.x)
    sync = interfaces.new(TIMESYNC_MSG, tc1=-(2**63), ts1=2**63 - 1)
    interfaces.validate(sync)


# --- deserialize(): malformed bytes ----------------------------------------------------


@pytest.mark.parametrize(
    "typename", ["px4_msgs/msg/VehicleOdometry", f"{QM}/msg/MissionEvent", TIMESYNC_MSG]
)
def test_deserialize_rejects_every_truncation(typename: str) -> None:
    msg = interfaces.new(typename)
    if typename.endswith("MissionEvent"):
        msg.message = "robot 14 found"
    data = interfaces.serialize(msg)
    for size in range(len(data)):
        with pytest.raises(MessageError, match="malformed"):
            interfaces.deserialize(data[:size], typename)


def test_deserialize_rejects_trailing_garbage_and_bad_lengths() -> None:
    data = interfaces.serialize(interfaces.new(TIMESYNC_MSG, seq=1))
    with pytest.raises(MessageError):
        interfaces.deserialize(data + bytes(8), TIMESYNC_MSG)
    with pytest.raises(MessageError):
        interfaces.deserialize(b"\x00\x01\x00\x00\xff\xff\xff\x7f", "std_msgs/String")


def test_deserialize_accepts_bytearray_and_memoryview() -> None:
    msg = interfaces.new(TIMESYNC_MSG, seq=9, tc1=5, ts1=6)
    data = interfaces.serialize(msg)
    for view in (bytearray(data), memoryview(data)):
        assert interfaces.messages_equal(interfaces.deserialize(view, TIMESYNC_MSG), msg)


# --- composed action and service types ---------------------------------------------


def test_there_are_the_documented_actions_and_services() -> None:
    assert set(ACTIONS) >= {
        "Takeoff",
        "Land",
        "Reach",
        "Turn",
        "Navigate",
        "Explore",
        "PrecisionLand",
    }
    assert set(SERVICES) >= {"Arm", "Disarm", "PlanPath"}


@pytest.mark.parametrize("name", ACTIONS)
def test_action_composed_types_have_the_ros2_shape(name: str) -> None:
    act = interfaces.get_action(f"{QM}/{name}")
    base = f"{QM}/action/{name}"
    uuid = (Nodetype.NAME, "unique_identifier_msgs/msg/UUID")

    assert fields_of(act.SendGoal.Request.__msgtype__) == [
        ("goal_id", uuid),
        ("goal", (Nodetype.NAME, f"{base}_Goal")),
    ]
    assert fields_of(act.SendGoal.Response.__msgtype__) == [
        ("accepted", (Nodetype.BASE, ("bool", 0))),
        ("stamp", (Nodetype.NAME, "builtin_interfaces/msg/Time")),
    ]
    assert fields_of(act.GetResult.Request.__msgtype__) == [("goal_id", uuid)]
    assert fields_of(act.GetResult.Response.__msgtype__) == [
        ("status", (Nodetype.BASE, ("int8", 0))),
        ("result", (Nodetype.NAME, f"{base}_Result")),
    ]
    assert fields_of(act.FeedbackMessage.__msgtype__) == [
        ("goal_id", uuid),
        ("feedback", (Nodetype.NAME, f"{base}_Feedback")),
    ]
    assert act.SendGoal.name == f"{base}_SendGoal"
    assert act.GetResult.name == f"{base}_GetResult"


def test_action_messages_round_trip_with_their_goal_id() -> None:
    act = interfaces.get_action(f"{QM}/Reach")
    goal_id = interfaces.new("unique_identifier_msgs/UUID", uuid=list(range(16)))
    goal = interfaces.new(act.Goal, radius=0.3, stop_at_target=True)
    goal.target.position.x = 2.5
    request = interfaces.new(act.SendGoal.Request, goal_id=goal_id, goal=goal)
    back = interfaces.deserialize(interfaces.serialize(request), act.SendGoal.Request.__msgtype__)
    assert back.goal_id.uuid.tolist() == list(range(16))
    assert back.goal.target.position.x == 2.5
    assert back.goal.stop_at_target is True

    fb = interfaces.new(act.Feedback, distance_left=1.25)
    message = interfaces.new(act.FeedbackMessage, goal_id=goal_id, feedback=fb)
    back = interfaces.deserialize(interfaces.serialize(message), act.FeedbackMessage.__msgtype__)
    assert back.feedback.distance_left == 1.25
    assert interfaces.messages_equal(back, message)


def test_cancel_goal_service_has_the_ros2_shape() -> None:
    svc = interfaces.cancel_goal_service()
    assert svc.name == "action_msgs/srv/CancelGoal"
    assert fields_of(svc.Request.__msgtype__) == [
        ("goal_info", (Nodetype.NAME, "action_msgs/msg/GoalInfo"))
    ]
    response = field_map(svc.Response.__msgtype__)
    assert response["return_code"] == (Nodetype.BASE, ("int8", 0))
    assert response["goals_canceling"] == (
        Nodetype.SEQUENCE,
        ((Nodetype.NAME, "action_msgs/msg/GoalInfo"), 0),
    )
    assert svc.Response.ERROR_NONE == 0
    assert svc.Response.ERROR_REJECTED == 1
    assert svc.Response.ERROR_UNKNOWN_GOAL_ID == 2
    assert svc.Response.ERROR_GOAL_TERMINATED == 3


# --- conventions of quadmission_interfaces --------------------------------------------


def _outcome_types() -> list[str]:
    out = [f"{QM}/action/{a}_Result" for a in ACTIONS]
    out += [f"{QM}/srv/{s}_Response" for s in SERVICES]
    return out


@pytest.mark.parametrize("typename", _outcome_types())
def test_results_and_responses_carry_success_and_message(typename: str) -> None:
    fields = field_map(typename)
    assert fields.get("success") == (Nodetype.BASE, ("bool", 0)), typename
    assert fields.get("message") == (Nodetype.BASE, ("string", 0)), typename


@pytest.mark.parametrize("typename", _outcome_types())
def test_result_codes_are_distinct(typename: str) -> None:
    consts, _ = interfaces.typestore().fielddefs[typename]
    codes = {name: value for name, _, value in consts if name.startswith("RESULT_")}
    if codes:
        assert "result" in field_map(typename), f"{typename} has RESULT_* but no result field"
        assert len(set(codes.values())) == len(codes), f"{typename}: duplicate codes {codes}"


FLOAT_FIELD = re.compile(r"^\s*float(32|64)(\[\d*\])?\s+[a-z_][a-z0-9_]*\s*(#.*)?$")


def test_every_physical_float_field_states_its_unit() -> None:
    # DESIGN.md "Frames, units, time": SI units, with the unit in a comment ('[m]', '[rad]',
    # '[-]' for dimensionless) on every float field of our own interfaces.
    missing, checked = [], 0
    for item in iter_interface_files():
        if item.package != QM:
            continue
        for number, line in enumerate(item.path.read_text(encoding="utf-8").splitlines(), 1):
            match = FLOAT_FIELD.match(line)
            checked += bool(match)
            if match and not re.search(r"\[[^\]]+\]", match.group(3) or ""):
                missing.append(f"{item.path.relative_to(INTERFACE_ROOT)}:{number}: {line.strip()}")
    assert checked > 30, f"only {checked} float fields found: is the pattern still right?"
    assert not missing, "float fields without a [unit] comment:\n" + "\n".join(missing)


def test_serialize_without_the_check_gives_the_same_bytes_and_still_refuses_what_cdr_cannot_hold(
) -> None:
    odom = interfaces.new("nav_msgs/msg/Odometry", child_frame_id="base_link")
    odom.pose.pose.position.x = 1.25
    assert interfaces.serialize(odom, check=False) == interfaces.serialize(odom)
    bad = interfaces.new("std_msgs/msg/String")
    bad.data = None
    with pytest.raises(MessageError, match="data: expected a string"):
        interfaces.serialize(bad)
    with pytest.raises(MessageError, match="cannot serialize std_msgs/msg/String"):
        interfaces.serialize(bad, check=False)


def test_point_is_a_geometry_point_of_python_floats() -> None:
    p = interfaces.point(1, np.float32(2.5), np.float64(-3.25))
    assert interfaces.type_name(p) == "geometry_msgs/msg/Point"
    assert (p.x, p.y, p.z) == (1.0, 2.5, -3.25)
    assert all(type(v) is float for v in (p.x, p.y, p.z))
