"""px4_msgs must match PX4's own definitions field for field, or the FCU link breaks.

The tables below are transcribed from the PX4-Autopilot msg files each of our .msg files
names in its first line (main around v1.16; Timesync from release/1.13). They are kept
apart from our .msg files on purpose: editing a .msg file without checking it against
PX4 fails here. CDR has no field names on the wire, so order and types are the contract.
"""

from __future__ import annotations

import re
from typing import Any

import pytest
from rosbags.interfaces import Nodetype

import interfaces
from interfaces.registry import INTERFACE_ROOT

# "type name" per line, in PX4's order.
PX4_FIELDS: dict[str, str] = {
    "VehicleOdometry": """
        uint64 timestamp
        uint64 timestamp_sample
        uint8 pose_frame
        float32[3] position
        float32[4] q
        uint8 velocity_frame
        float32[3] velocity
        float32[3] angular_velocity
        float32[3] position_variance
        float32[3] orientation_variance
        float32[3] velocity_variance
        uint8 reset_counter
        int8 quality
    """,
    "VehicleLocalPosition": """
        uint64 timestamp
        uint64 timestamp_sample
        bool xy_valid
        bool z_valid
        bool v_xy_valid
        bool v_z_valid
        float32 x
        float32 y
        float32 z
        float32[2] delta_xy
        uint8 xy_reset_counter
        float32 delta_z
        uint8 z_reset_counter
        float32 vx
        float32 vy
        float32 vz
        float32 z_deriv
        float32[2] delta_vxy
        uint8 vxy_reset_counter
        float32 delta_vz
        uint8 vz_reset_counter
        float32 ax
        float32 ay
        float32 az
        float32 heading
        float32 heading_var
        float32 unaided_heading
        float32 delta_heading
        uint8 heading_reset_counter
        bool heading_good_for_control
        float32 tilt_var
        bool xy_global
        bool z_global
        uint64 ref_timestamp
        float64 ref_lat
        float64 ref_lon
        float32 ref_alt
        bool dist_bottom_valid
        float32 dist_bottom
        float32 dist_bottom_var
        float32 delta_dist_bottom
        uint8 dist_bottom_reset_counter
        uint8 dist_bottom_sensor_bitfield
        float32 eph
        float32 epv
        float32 evh
        float32 evv
        bool dead_reckoning
        float32 vxy_max
        float32 vz_max
        float32 hagl_min
        float32 hagl_max_z
        float32 hagl_max_xy
    """,
    "VehicleAttitude": """
        uint64 timestamp
        uint64 timestamp_sample
        float32[4] q
        float32[4] delta_q_reset
        uint8 quat_reset_counter
    """,
    "VehicleStatus": """
        uint64 timestamp
        uint64 armed_time
        uint64 takeoff_time
        uint8 arming_state
        uint8 latest_arming_reason
        uint8 latest_disarming_reason
        uint64 nav_state_timestamp
        uint8 nav_state_user_intention
        uint8 nav_state
        uint8 executor_in_charge
        uint32 valid_nav_states_mask
        uint32 can_set_nav_states_mask
        uint16 failure_detector_status
        uint8 hil_state
        uint8 vehicle_type
        bool failsafe
        bool failsafe_and_user_took_over
        uint8 failsafe_defer_state
        bool gcs_connection_lost
        uint8 gcs_connection_lost_counter
        bool high_latency_data_link_lost
        bool is_vtol
        bool is_vtol_tailsitter
        bool in_transition_mode
        bool in_transition_to_fw
        uint8 system_type
        uint8 system_id
        uint8 component_id
        bool safety_button_available
        bool safety_off
        bool power_input_valid
        bool usb_connected
        bool open_drone_id_system_present
        bool open_drone_id_system_healthy
        bool parachute_system_present
        bool parachute_system_healthy
        bool avoidance_system_required
        bool avoidance_system_valid
        bool rc_calibration_in_progress
        bool calibration_enabled
        bool pre_flight_checks_pass
    """,
    "VehicleCommand": """
        uint64 timestamp
        float32 param1
        float32 param2
        float32 param3
        float32 param4
        float64 param5
        float64 param6
        float32 param7
        uint32 command
        uint8 target_system
        uint8 target_component
        uint8 source_system
        uint16 source_component
        uint8 confirmation
        bool from_external
    """,
    "VehicleCommandAck": """
        uint64 timestamp
        uint32 command
        uint8 result
        uint8 result_param1
        int32 result_param2
        uint8 target_system
        uint16 target_component
        bool from_external
    """,
    "OffboardControlMode": """
        uint64 timestamp
        bool position
        bool velocity
        bool acceleration
        bool attitude
        bool body_rate
        bool thrust_and_torque
        bool direct_actuator
    """,
    "TrajectorySetpoint": """
        uint64 timestamp
        float32[3] position
        float32[3] velocity
        float32[3] acceleration
        float32[3] jerk
        float32 yaw
        float32 yawspeed
    """,
    "BatteryStatus": """
        uint64 timestamp
        uint8 id
        bool connected
        float32 voltage_v
        float32 current_a
        float32 current_average_a
        float32 discharged_mah
        float32 remaining
        float32 scale
        float32 time_remaining_s
        float32 temperature
        uint8 priority
        uint16 interface_error
        float32[14] voltage_cell_v
        float32 max_cell_voltage_delta
        bool is_powering_off
        bool is_required
        uint8 warning
        uint16 faults
        float32 ocv_estimate
        float32 ocv_estimate_filtered
        float32 volt_based_soc_estimate
        float32 voltage_prediction
        float32 prediction_error
        float32 estimation_covariance_norm
        uint8 cell_count
        uint8 source
        uint16 capacity
        uint16 cycle_count
        uint16 average_time_to_empty
        char[32] serial_number
        uint16 manufacture_date
        uint16 state_of_health
        uint16 max_error
        float32 design_capacity_wh
        float32 full_charge_capacity_wh
        float32 remaining_capacity_wh
        uint16 over_discharge_count
        float32 nominal_voltage
        float32 internal_resistance_estimate
    """,
    "SensorCombined": """
        uint64 timestamp
        float32[3] gyro_rad
        uint32 gyro_integral_dt
        int32 accelerometer_timestamp_relative
        float32[3] accelerometer_m_s2
        uint32 accelerometer_integral_dt
        uint8 accelerometer_clipping
        uint8 gyro_clipping
        uint8 accel_calibration_count
        uint8 gyro_calibration_count
    """,
    "VehicleLandDetected": """
        uint64 timestamp
        bool freefall
        bool ground_contact
        bool maybe_landed
        bool landed
        bool in_ground_effect
        bool in_descend
        bool has_low_throttle
        bool vertical_movement
        bool horizontal_movement
        bool rotational_movement
        bool close_to_ground_or_skipped_check
        bool at_rest
    """,
    "FailsafeFlags": """
        uint64 timestamp
        uint32 mode_req_angular_velocity
        uint32 mode_req_attitude
        uint32 mode_req_local_alt
        uint32 mode_req_local_position
        uint32 mode_req_local_position_relaxed
        uint32 mode_req_global_position
        uint32 mode_req_global_position_relaxed
        uint32 mode_req_mission
        uint32 mode_req_offboard_signal
        uint32 mode_req_home_position
        uint32 mode_req_wind_and_flight_time_compliance
        uint32 mode_req_prevent_arming
        uint32 mode_req_manual_control
        uint32 mode_req_other
        uint32 mode_req_not_possible
        bool angular_velocity_invalid
        bool attitude_invalid
        bool local_altitude_invalid
        bool local_position_invalid
        bool local_position_invalid_relaxed
        bool local_velocity_invalid
        bool global_position_invalid
        bool global_position_invalid_relaxed
        bool auto_mission_missing
        bool offboard_control_signal_lost
        bool home_position_invalid
        bool manual_control_signal_lost
        bool gcs_connection_lost
        uint8 battery_warning
        bool battery_low_remaining_time
        bool battery_unhealthy
        bool fd_critical_failure
        bool fd_esc_arming_failure
        bool fd_imbalanced_prop
        bool fd_motor_failure
        bool fd_alt_loss
        bool geofence_breached
        bool mission_failure
        bool vtol_fixed_wing_system_failure
        bool wind_limit_exceeded
        bool flight_time_limit_exceeded
        bool position_accuracy_low
        bool navigator_failure
        bool parachute_unhealthy
        bool traffic_avoidance_unhealthy
        bool remote_id_unhealthy
        bool gnss_lost
    """,
    "TimesyncStatus": """
        uint64 timestamp
        uint8 source_protocol
        uint64 remote_timestamp
        int64 observed_offset
        int64 estimated_offset
        uint32 round_trip_time
    """,
    "Timesync": """
        uint64 timestamp
        uint8 seq
        int64 tc1
        int64 ts1
    """,
}

# "type NAME = value" per line: every constant of the message, as in PX4 (order free).
PX4_CONSTANTS: dict[str, str] = {
    "VehicleOdometry": """
        uint32 MESSAGE_VERSION = 0
        uint8 POSE_FRAME_UNKNOWN = 0
        uint8 POSE_FRAME_NED = 1
        uint8 POSE_FRAME_FRD = 2
        uint8 VELOCITY_FRAME_UNKNOWN = 0
        uint8 VELOCITY_FRAME_NED = 1
        uint8 VELOCITY_FRAME_FRD = 2
        uint8 VELOCITY_FRAME_BODY_FRD = 3
    """,
    "VehicleLocalPosition": """
        uint32 MESSAGE_VERSION = 1
        uint8 DIST_BOTTOM_SENSOR_NONE = 0
        uint8 DIST_BOTTOM_SENSOR_RANGE = 1
        uint8 DIST_BOTTOM_SENSOR_FLOW = 2
    """,
    "VehicleAttitude": """
        uint32 MESSAGE_VERSION = 0
    """,
    "VehicleStatus": """
        uint32 MESSAGE_VERSION = 0
        uint8 ARMING_STATE_DISARMED = 1
        uint8 ARMING_STATE_ARMED = 2
        uint8 ARM_DISARM_REASON_TRANSITION_TO_STANDBY = 0
        uint8 ARM_DISARM_REASON_STICK_GESTURE = 1
        uint8 ARM_DISARM_REASON_RC_SWITCH = 2
        uint8 ARM_DISARM_REASON_COMMAND_INTERNAL = 3
        uint8 ARM_DISARM_REASON_COMMAND_EXTERNAL = 4
        uint8 ARM_DISARM_REASON_MISSION_START = 5
        uint8 ARM_DISARM_REASON_SAFETY_BUTTON = 6
        uint8 ARM_DISARM_REASON_AUTO_DISARM_LAND = 7
        uint8 ARM_DISARM_REASON_AUTO_DISARM_PREFLIGHT = 8
        uint8 ARM_DISARM_REASON_KILL_SWITCH = 9
        uint8 ARM_DISARM_REASON_LOCKDOWN = 10
        uint8 ARM_DISARM_REASON_FAILURE_DETECTOR = 11
        uint8 ARM_DISARM_REASON_SHUTDOWN = 12
        uint8 ARM_DISARM_REASON_UNIT_TEST = 13
        uint8 NAVIGATION_STATE_MANUAL = 0
        uint8 NAVIGATION_STATE_ALTCTL = 1
        uint8 NAVIGATION_STATE_POSCTL = 2
        uint8 NAVIGATION_STATE_AUTO_MISSION = 3
        uint8 NAVIGATION_STATE_AUTO_LOITER = 4
        uint8 NAVIGATION_STATE_AUTO_RTL = 5
        uint8 NAVIGATION_STATE_POSITION_SLOW = 6
        uint8 NAVIGATION_STATE_FREE5 = 7
        uint8 NAVIGATION_STATE_FREE4 = 8
        uint8 NAVIGATION_STATE_FREE3 = 9
        uint8 NAVIGATION_STATE_ACRO = 10
        uint8 NAVIGATION_STATE_FREE2 = 11
        uint8 NAVIGATION_STATE_DESCEND = 12
        uint8 NAVIGATION_STATE_TERMINATION = 13
        uint8 NAVIGATION_STATE_OFFBOARD = 14
        uint8 NAVIGATION_STATE_STAB = 15
        uint8 NAVIGATION_STATE_CS_PREFLIGHT_CHECK = 16
        uint8 NAVIGATION_STATE_AUTO_TAKEOFF = 17
        uint8 NAVIGATION_STATE_AUTO_LAND = 18
        uint8 NAVIGATION_STATE_AUTO_FOLLOW_TARGET = 19
        uint8 NAVIGATION_STATE_AUTO_PRECLAND = 20
        uint8 NAVIGATION_STATE_ORBIT = 21
        uint8 NAVIGATION_STATE_AUTO_VTOL_TAKEOFF = 22
        uint8 NAVIGATION_STATE_EXTERNAL1 = 23
        uint8 NAVIGATION_STATE_EXTERNAL2 = 24
        uint8 NAVIGATION_STATE_EXTERNAL3 = 25
        uint8 NAVIGATION_STATE_EXTERNAL4 = 26
        uint8 NAVIGATION_STATE_EXTERNAL5 = 27
        uint8 NAVIGATION_STATE_EXTERNAL6 = 28
        uint8 NAVIGATION_STATE_EXTERNAL7 = 29
        uint8 NAVIGATION_STATE_EXTERNAL8 = 30
        uint8 NAVIGATION_STATE_MAX = 31
        uint16 FAILURE_NONE = 0
        uint16 FAILURE_ROLL = 1
        uint16 FAILURE_PITCH = 2
        uint16 FAILURE_ALT = 4
        uint16 FAILURE_EXT = 8
        uint16 FAILURE_ARM_ESC = 16
        uint16 FAILURE_BATTERY = 32
        uint16 FAILURE_IMBALANCED_PROP = 64
        uint16 FAILURE_MOTOR = 128
        uint8 HIL_STATE_OFF = 0
        uint8 HIL_STATE_ON = 1
        uint8 VEHICLE_TYPE_UNKNOWN = 0
        uint8 VEHICLE_TYPE_ROTARY_WING = 1
        uint8 VEHICLE_TYPE_FIXED_WING = 2
        uint8 VEHICLE_TYPE_ROVER = 3
        uint8 VEHICLE_TYPE_AIRSHIP = 4
        uint8 FAILSAFE_DEFER_STATE_DISABLED = 0
        uint8 FAILSAFE_DEFER_STATE_ENABLED = 1
        uint8 FAILSAFE_DEFER_STATE_WOULD_FAILSAFE = 2
    """,
    "VehicleCommandAck": """
        uint32 MESSAGE_VERSION = 1
        uint8 ORB_QUEUE_LENGTH = 8
        uint8 VEHICLE_CMD_RESULT_ACCEPTED = 0
        uint8 VEHICLE_CMD_RESULT_TEMPORARILY_REJECTED = 1
        uint8 VEHICLE_CMD_RESULT_DENIED = 2
        uint8 VEHICLE_CMD_RESULT_UNSUPPORTED = 3
        uint8 VEHICLE_CMD_RESULT_FAILED = 4
        uint8 VEHICLE_CMD_RESULT_IN_PROGRESS = 5
        uint8 VEHICLE_CMD_RESULT_CANCELLED = 6
        uint8 VEHICLE_CMD_RESULT_COMMAND_LONG_ONLY = 7
        uint8 VEHICLE_CMD_RESULT_COMMAND_INT_ONLY = 8
        uint8 VEHICLE_CMD_RESULT_UNSUPPORTED_MAV_FRAME = 9
        uint16 ARM_AUTH_DENIED_REASON_GENERIC = 0
        uint16 ARM_AUTH_DENIED_REASON_NONE = 1
        uint16 ARM_AUTH_DENIED_REASON_INVALID_WAYPOINT = 2
        uint16 ARM_AUTH_DENIED_REASON_TIMEOUT = 3
        uint16 ARM_AUTH_DENIED_REASON_AIRSPACE_IN_USE = 4
        uint16 ARM_AUTH_DENIED_REASON_BAD_WEATHER = 5
    """,
    "OffboardControlMode": "",
    "TrajectorySetpoint": """
        uint32 MESSAGE_VERSION = 0
    """,
    "BatteryStatus": """
        uint32 MESSAGE_VERSION = 0
        uint8 MAX_INSTANCES = 4
        uint8 WARNING_NONE = 0
        uint8 BATTERY_WARNING_LOW = 1
        uint8 BATTERY_WARNING_CRITICAL = 2
        uint8 BATTERY_WARNING_EMERGENCY = 3
        uint8 BATTERY_WARNING_FAILED = 4
        uint8 BATTERY_STATE_UNHEALTHY = 6
        uint8 BATTERY_STATE_CHARGING = 7
        uint8 BATTERY_FAULT_DEEP_DISCHARGE = 0
        uint8 BATTERY_FAULT_SPIKES = 1
        uint8 BATTERY_FAULT_CELL_FAIL = 2
        uint8 BATTERY_FAULT_OVER_CURRENT = 3
        uint8 BATTERY_FAULT_OVER_TEMPERATURE = 4
        uint8 BATTERY_FAULT_UNDER_TEMPERATURE = 5
        uint8 BATTERY_FAULT_INCOMPATIBLE_VOLTAGE = 6
        uint8 BATTERY_FAULT_INCOMPATIBLE_FIRMWARE = 7
        uint8 BATTERY_FAULT_INCOMPATIBLE_MODEL = 8
        uint8 BATTERY_FAULT_HARDWARE_FAILURE = 9
        uint8 BATTERY_FAULT_FAILED_TO_ARM = 10
        uint8 BATTERY_FAULT_COUNT = 11
        uint8 SOURCE_POWER_MODULE = 0
        uint8 SOURCE_EXTERNAL = 1
        uint8 SOURCE_ESCS = 2
    """,
    "SensorCombined": """
        int32 RELATIVE_TIMESTAMP_INVALID = 2147483647
        uint8 CLIPPING_X = 1
        uint8 CLIPPING_Y = 2
        uint8 CLIPPING_Z = 4
    """,
    "VehicleLandDetected": """
        uint32 MESSAGE_VERSION = 0
    """,
    "FailsafeFlags": "",
    "TimesyncStatus": """
        uint8 SOURCE_PROTOCOL_UNKNOWN = 0
        uint8 SOURCE_PROTOCOL_MAVLINK = 1
        uint8 SOURCE_PROTOCOL_DDS = 2
    """,
    "Timesync": "",
}

# VehicleCommand has 157 constants; these are the ones the companion relies on, plus a
# spread of others, each as in PX4. The count below catches additions and removals.
VEHICLE_COMMAND_CONSTANTS = """
    uint32 MESSAGE_VERSION = 0
    uint16 VEHICLE_CMD_CUSTOM_0 = 0
    uint16 VEHICLE_CMD_NAV_WAYPOINT = 16
    uint16 VEHICLE_CMD_NAV_LOITER_UNLIM = 17
    uint16 VEHICLE_CMD_NAV_RETURN_TO_LAUNCH = 20
    uint16 VEHICLE_CMD_NAV_LAND = 21
    uint16 VEHICLE_CMD_NAV_TAKEOFF = 22
    uint16 VEHICLE_CMD_NAV_PRECLAND = 23
    uint16 VEHICLE_CMD_DO_ORBIT = 34
    uint16 VEHICLE_CMD_CONDITION_YAW = 115
    uint16 VEHICLE_CMD_CONDITION_GATE = 4501
    uint16 VEHICLE_CMD_DO_SET_MODE = 176
    uint16 VEHICLE_CMD_DO_CHANGE_SPEED = 178
    uint16 VEHICLE_CMD_DO_SET_HOME = 179
    uint16 VEHICLE_CMD_DO_FLIGHTTERMINATION = 185
    uint16 VEHICLE_CMD_DO_REPOSITION = 192
    uint16 VEHICLE_CMD_DO_PAUSE_CONTINUE = 193
    uint16 VEHICLE_CMD_DO_DIGICAM_CONTROL = 203
    uint16 VEHICLE_CMD_DO_GUIDED_LIMITS = 222
    uint16 VEHICLE_CMD_DO_LAST = 240
    uint16 VEHICLE_CMD_PREFLIGHT_CALIBRATION = 241
    uint16 PREFLIGHT_CALIBRATION_TEMPERATURE_CALIBRATION = 3
    uint16 VEHICLE_CMD_PREFLIGHT_REBOOT_SHUTDOWN = 246
    uint16 VEHICLE_CMD_DO_SET_STANDARD_MODE = 262
    uint16 VEHICLE_CMD_MISSION_START = 300
    uint16 VEHICLE_CMD_COMPONENT_ARM_DISARM = 400
    uint16 VEHICLE_CMD_RUN_PREARM_CHECKS = 401
    uint16 VEHICLE_CMD_INJECT_FAILURE = 420
    uint16 VEHICLE_CMD_REQUEST_MESSAGE = 512
    uint16 VEHICLE_CMD_DO_VTOL_TRANSITION = 3000
    uint16 VEHICLE_CMD_PAYLOAD_CONTROL_DEPLOY = 30002
    uint16 VEHICLE_CMD_DO_WINCH = 42600
    uint16 VEHICLE_CMD_EXTERNAL_POSITION_ESTIMATE = 43003
    uint16 VEHICLE_CMD_EXTERNAL_WIND_ESTIMATE = 43004
    uint32 VEHICLE_CMD_PX4_INTERNAL_START = 65537
    uint32 VEHICLE_CMD_SET_GPS_GLOBAL_ORIGIN = 100000
    uint32 VEHICLE_CMD_SET_NAV_STATE = 100001
    uint8 VEHICLE_MOUNT_MODE_ENUM_END = 5
    uint8 VEHICLE_ROI_TARGET = 4
    uint8 PARACHUTE_ACTION_RELEASE = 2
    uint8 FAILURE_UNIT_SENSOR_AIRSPEED = 8
    uint8 FAILURE_UNIT_SYSTEM_MAVLINK_SIGNAL = 105
    uint8 FAILURE_TYPE_INTERMITTENT = 7
    uint8 SPEED_TYPE_DESCEND_SPEED = 3
    uint8 ORBIT_YAW_BEHAVIOUR_UNCHANGED = 5
    int8 ARMING_ACTION_DISARM = 0
    int8 ARMING_ACTION_ARM = 1
    uint8 GRIPPER_ACTION_GRAB = 1
    uint8 ORB_QUEUE_LENGTH = 8
    uint16 COMPONENT_MODE_EXECUTOR_START = 1000
"""
VEHICLE_COMMAND_CONSTANT_COUNT = 157


def _px4(name: str) -> str:
    return f"px4_msgs/msg/{name}"


def describe(node: tuple[Any, Any]) -> str:
    """A field type as written in a .msg file: 'uint8', 'float32[3]', 'string<=8', 'T[]'."""
    kind, arg = node
    if kind == Nodetype.BASE:
        base, bound = arg
        return f"{base}<={bound}" if bound else base
    if kind == Nodetype.NAME:
        return str(arg)
    sub, length = arg
    if kind == Nodetype.ARRAY:
        return f"{describe(sub)}[{length}]"
    return f"{describe(sub)}[<={length}]" if length else f"{describe(sub)}[]"


def parse_fields(table: str) -> list[tuple[str, str]]:
    rows = [line.split() for line in table.strip().splitlines()]
    return [(name, typ) for typ, name in rows]


def parse_constants(table: str) -> dict[str, tuple[str, int]]:
    out: dict[str, tuple[str, int]] = {}
    for line in table.strip().splitlines():
        match = re.fullmatch(r"\s*(\w+) (\w+) = (-?\d+)\s*", line)
        assert match, f"bad reference line {line!r}"
        typ, name, value = match.groups()
        assert name not in out, f"{name} listed twice"
        out[name] = (typ, int(value))
    return out


def our_fields(name: str) -> list[tuple[str, str]]:
    _, fields = interfaces.typestore().fielddefs[_px4(name)]
    return [(fname, describe(node)) for fname, node in fields]


def our_constants(name: str) -> dict[str, tuple[str, int]]:
    consts, _ = interfaces.typestore().fielddefs[_px4(name)]
    out: dict[str, tuple[str, int]] = {}
    for cname, ctype, value in consts:
        assert cname not in out, f"{name}.{cname} defined twice"
        out[cname] = (ctype, value)
    return out


def test_reference_covers_exactly_the_registered_px4_messages() -> None:
    registered = {n.rsplit("/", 1)[-1] for n in interfaces.registered_types("px4_msgs")}
    assert registered == set(PX4_FIELDS)
    assert set(PX4_CONSTANTS) | {"VehicleCommand"} == set(PX4_FIELDS)


@pytest.mark.parametrize("name", sorted(PX4_FIELDS))
def test_fields_match_px4(name: str) -> None:
    want = parse_fields(PX4_FIELDS[name])
    got = our_fields(name)
    assert [f for f, _ in got] == [f for f, _ in want], f"{name}: field names or order differ"
    for (fname, want_type), (_, got_type) in zip(want, got, strict=True):
        assert got_type == want_type, f"{name}.{fname}: {got_type} != PX4 {want_type}"


@pytest.mark.parametrize("name", sorted(PX4_CONSTANTS))
def test_constants_match_px4(name: str) -> None:
    assert our_constants(name) == parse_constants(PX4_CONSTANTS[name])


def test_vehicle_command_constants_match_px4() -> None:
    ours = our_constants("VehicleCommand")
    for cname, value in parse_constants(VEHICLE_COMMAND_CONSTANTS).items():
        assert ours.get(cname) == value, f"VehicleCommand.{cname}: {ours.get(cname)} != {value}"
    assert len(ours) == VEHICLE_COMMAND_CONSTANT_COUNT
    commands = {k: v for k, (_, v) in ours.items() if k.startswith("VEHICLE_CMD_")}
    assert len(set(commands.values())) == len(commands), "two VEHICLE_CMD_* share a value"


def test_key_constants_on_the_message_classes() -> None:
    # What the bridge and the simulated FCU use, read the way node code reads them.
    cmd = interfaces.get_message("px4_msgs/VehicleCommand")
    assert cmd.VEHICLE_CMD_COMPONENT_ARM_DISARM == 400
    assert cmd.VEHICLE_CMD_DO_SET_MODE == 176
    assert cmd.VEHICLE_CMD_NAV_LAND == 21
    assert cmd.VEHICLE_CMD_NAV_TAKEOFF == 22
    assert cmd.VEHICLE_CMD_NAV_PRECLAND == 23
    assert cmd.VEHICLE_CMD_NAV_RETURN_TO_LAUNCH == 20
    assert cmd.VEHICLE_CMD_SET_NAV_STATE == 100001
    assert cmd.ARMING_ACTION_ARM == 1
    assert cmd.ARMING_ACTION_DISARM == 0
    status = interfaces.get_message("px4_msgs/VehicleStatus")
    assert status.NAVIGATION_STATE_OFFBOARD == 14
    assert status.NAVIGATION_STATE_AUTO_LAND == 18
    assert status.NAVIGATION_STATE_AUTO_TAKEOFF == 17
    assert status.NAVIGATION_STATE_AUTO_LOITER == 4
    assert status.ARMING_STATE_DISARMED == 1
    assert status.ARMING_STATE_ARMED == 2
    odom = interfaces.get_message("px4_msgs/VehicleOdometry")
    assert odom.POSE_FRAME_NED == 1
    assert odom.POSE_FRAME_FRD == 2
    assert odom.VELOCITY_FRAME_NED == 1
    assert odom.VELOCITY_FRAME_BODY_FRD == 3
    ack = interfaces.get_message("px4_msgs/VehicleCommandAck")
    assert ack.VEHICLE_CMD_RESULT_ACCEPTED == 0
    assert ack.VEHICLE_CMD_RESULT_TEMPORARILY_REJECTED == 1
    assert ack.VEHICLE_CMD_RESULT_DENIED == 2
    assert ack.VEHICLE_CMD_RESULT_IN_PROGRESS == 5
    sync = interfaces.get_message("px4_msgs/TimesyncStatus")
    assert sync.SOURCE_PROTOCOL_DDS == 2
    battery = interfaces.get_message("px4_msgs/BatteryStatus")
    assert battery.BATTERY_WARNING_CRITICAL == 2


def test_command_ids_fit_the_command_field() -> None:
    # VehicleCommand.command is uint32 so PX4-internal ids (> UINT16_MAX) fit.
    msg = interfaces.new("px4_msgs/VehicleCommand", command=100001)
    back = interfaces.deserialize(interfaces.serialize(msg), "px4_msgs/VehicleCommand")
    assert back.command == 100001


@pytest.mark.parametrize("name", sorted(PX4_FIELDS))
def test_each_file_names_the_px4_file_it_mirrors(name: str) -> None:
    text = (INTERFACE_ROOT / "px4_msgs" / "msg" / f"{name}.msg").read_text(encoding="utf-8")
    first = text.splitlines()[0]
    match = re.match(
        r"# Mirrors PX4/PX4-Autopilot (msg/\S+\.msg) (@ [0-9a-f]{12}|on release/)", first
    )
    assert match, f"{name}.msg must start with '# Mirrors PX4/PX4-Autopilot msg/<file> @ <commit>'"
    assert match.group(1).rsplit("/", 1)[-1].lower() == f"{name}.msg".lower()
