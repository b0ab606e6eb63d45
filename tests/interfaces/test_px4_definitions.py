"""px4_msgs must equal PX4 v1.17.0's field for field, or the FCU link breaks.

The reference table ``px4_msgs_v1.17.0.json`` was read from github.com/PX4/px4_msgs at tag
v1.17.0 (the commit is in it and in ``interfaces/px4_msgs/PX4_RELEASE``): for every file,
the fields in order with their types and array sizes, every constant with its type and
value, and the file's SHA-256. It is kept apart from our .msg files on purpose: editing a
.msg file without checking it against PX4 fails here. CDR has no field names on the wire,
so order and types are the contract.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

import pytest
from rosbags.interfaces import Nodetype

import interfaces
from interfaces.registry import INTERFACE_ROOT

REFERENCE = json.loads((Path(__file__).parent / "px4_msgs_v1.17.0.json").read_text())
PX4_MESSAGES: dict[str, Any] = REFERENCE["messages"]
MSG_DIR = INTERFACE_ROOT / "px4_msgs" / "msg"


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


def _px4(name: str) -> str:
    return f"px4_msgs/msg/{name}"


def test_release_file_names_the_reference_release() -> None:
    release = (INTERFACE_ROOT / "px4_msgs" / "PX4_RELEASE").read_text().splitlines()[0]
    assert release == REFERENCE["release"] == "v1.17.0"
    assert REFERENCE["px4_msgs_commit"] in (INTERFACE_ROOT / "px4_msgs" / "PX4_RELEASE").read_text()


def test_reference_covers_exactly_the_registered_px4_messages() -> None:
    registered = {n.rsplit("/", 1)[-1] for n in interfaces.registered_types("px4_msgs")}
    assert registered == set(PX4_MESSAGES)
    assert {p.stem for p in MSG_DIR.glob("*.msg")} == set(PX4_MESSAGES)


@pytest.mark.parametrize("name", sorted(PX4_MESSAGES))
def test_fields_match_px4(name: str) -> None:
    _, fields = interfaces.typestore().fielddefs[_px4(name)]
    got = [[fname, describe(node)] for fname, node in fields]
    want = PX4_MESSAGES[name]["fields"]
    assert [f for f, _ in got] == [f for f, _ in want], f"{name}: field names or order differ"
    for (fname, want_type), (_, got_type) in zip(want, got, strict=True):
        assert got_type == want_type, f"{name}.{fname}: {got_type} != PX4 {want_type}"


@pytest.mark.parametrize("name", sorted(PX4_MESSAGES))
def test_constants_match_px4(name: str) -> None:
    consts, _ = interfaces.typestore().fielddefs[_px4(name)]
    got = {cname: (ctype, value) for cname, ctype, value in consts}
    assert len(got) == len(consts), f"{name}: a constant is defined twice"
    want = {cname: (ctype, value) for cname, ctype, value in PX4_MESSAGES[name]["constants"]}
    assert got == want


@pytest.mark.parametrize("name", sorted(PX4_MESSAGES))
def test_files_are_the_release_files(name: str) -> None:
    digest = hashlib.sha256((MSG_DIR / f"{name}.msg").read_bytes()).hexdigest()
    assert digest == PX4_MESSAGES[name]["sha256"], f"{name}.msg differs from PX4 v1.17.0's"


def test_key_constants_on_the_message_classes() -> None:
    # What the bridge and the simulated FCU use, read the way node code reads them.
    cmd = interfaces.get_message("px4_msgs/VehicleCommand")
    assert cmd.VEHICLE_CMD_COMPONENT_ARM_DISARM == 400
    assert cmd.VEHICLE_CMD_DO_SET_MODE == 176
    assert cmd.VEHICLE_CMD_NAV_LAND == 21
    assert cmd.VEHICLE_CMD_SET_NAV_STATE == 100001
    status = interfaces.get_message("px4_msgs/VehicleStatus")
    assert status.MESSAGE_VERSION == 1
    assert status.NAVIGATION_STATE_OFFBOARD == 14
    assert status.ARMING_STATE_ARMED == 2
    battery = interfaces.get_message("px4_msgs/BatteryStatus")
    assert battery.WARNING_CRITICAL == 2


def test_command_ids_fit_the_command_field() -> None:
    # VehicleCommand.command is uint32 so PX4-internal ids (> UINT16_MAX) fit.
    msg = interfaces.new("px4_msgs/VehicleCommand", command=100001)
    back = interfaces.deserialize(interfaces.serialize(msg), "px4_msgs/VehicleCommand")
    assert back.command == 100001
