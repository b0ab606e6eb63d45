"""CDR round trip of every px4_msgs, quadmission_interfaces and action_msgs service type.

Each message is filled with non-default values in every field (driven by the typestore's
field definitions), serialized, deserialized, and compared with messages_equal and field
by field, so a type whose fields are lost, reordered, truncated or mistyped on the wire
fails here.
"""

from __future__ import annotations

import string
import struct
import zlib
from typing import Any

import numpy as np
import pytest
from rosbags.interfaces import Nodetype

import interfaces
from interfaces.api import NUMPY_DTYPES

TIMESYNC_MSG = "quadmission_interfaces/msg/Timesync"  # the modelled XRCE session sync

CDR_LE_HEADER = b"\x00\x01\x00\x00"  # XCDR1 encapsulation CDR_LE, options 0
PACKAGES = ("px4_msgs", "quadmission_interfaces")
MAX_SEQUENCE = 3  # elements in an unbounded sequence
MAX_STRING = 12  # characters in an unbounded string


def types_under_test() -> list[str]:
    names = [n for pkg in PACKAGES for n in interfaces.registered_types(pkg)]
    names += [n for n in interfaces.registered_types("action_msgs") if "/srv/" in n]
    return names


TYPES = types_under_test()


def _fielddefs(typename: str) -> list[tuple[str, Any]]:
    return list(interfaces.typestore().fielddefs[typename][1])


class Filler:
    """Fills a message with values that differ from the ROS defaults, from a seeded RNG.

    ``extreme`` picks integer fields at the ends of their range (alternating min and
    max, never 0) and strings at their bound, to exercise sign and width on the wire.
    """

    def __init__(self, seed: int, *, extreme: bool = False) -> None:
        self.rng = np.random.default_rng(seed)
        self.extreme = extreme
        self._flip = False

    def message(self, typename: str) -> Any:
        fields = {name: self.value(node) for name, node in _fielddefs(typename)}
        return interfaces.new(typename, **fields)

    def value(self, node: tuple[Any, Any]) -> Any:
        kind, arg = node
        if kind == Nodetype.BASE:
            return self.scalar(arg[0], arg[1])
        if kind == Nodetype.NAME:
            return self.message(arg)
        sub, length = arg
        if kind == Nodetype.ARRAY or length:  # fixed array, or bounded sequence to its bound
            count = length
        else:
            count = int(self.rng.integers(1, MAX_SEQUENCE, endpoint=True))
        items = [self.value(sub) for _ in range(count)]
        if sub[0] == Nodetype.BASE and sub[1][0] in NUMPY_DTYPES:
            return np.array(items, dtype=NUMPY_DTYPES[sub[1][0]])
        return items

    def scalar(self, base: str, bound: int) -> Any:
        if base in ("string", "wstring"):
            size = bound or MAX_STRING
            if not self.extreme:
                size = int(self.rng.integers(1, size, endpoint=True))
            letters = self.rng.choice(list(string.ascii_letters + string.digits + " _/"), size)
            return "".join(letters)
        if base == "bool":
            return True
        if base in ("float32", "float64"):
            magnitude = float(self.rng.uniform(0.5, 1e4))
            value = magnitude if self.rng.integers(2) else -magnitude
            # a float32 field holds what float32 can represent, so the round trip is exact
            return float(np.float32(value)) if base == "float32" else value
        info = np.iinfo(NUMPY_DTYPES[base])
        lo, hi = int(info.min), int(info.max)
        if self.extreme:
            self._flip = not self._flip
            return lo if (self._flip and lo < 0) else hi
        value = int(self.rng.integers(max(lo, -(2**62)), min(hi, 2**62), endpoint=True))
        return value if value != 0 else 1


def assert_fields_equal(typename: str, want: Any, got: Any, path: str = "") -> None:
    """Compare two messages field by field, with the field path in any failure."""
    assert interfaces.type_name(got) == typename, path or typename
    for name, node in _fielddefs(typename):
        _assert_value_equal(node, getattr(want, name), getattr(got, name), f"{path}.{name}")


def _assert_value_equal(node: tuple[Any, Any], want: Any, got: Any, path: str) -> None:
    kind, arg = node
    if kind == Nodetype.BASE:
        if arg[0] == "bool":
            assert bool(got) is bool(want), path
        else:
            assert got == want, f"{path}: sent {want!r}, received {got!r}"
            assert not isinstance(got, bool), f"{path}: received a bool for {arg[0]}"
        return
    if kind == Nodetype.NAME:
        assert_fields_equal(arg, want, got, path)
        return
    sub = arg[0]
    assert len(got) == len(want), f"{path}: sent {len(want)} elements, received {len(got)}"
    if isinstance(want, np.ndarray):
        assert isinstance(got, np.ndarray), f"{path}: received {type(got).__name__}"
        assert got.dtype == want.dtype, f"{path}: dtype {got.dtype} != {want.dtype}"
        np.testing.assert_array_equal(got, want, err_msg=path)
        return
    for i, (w, g) in enumerate(zip(want, got, strict=True)):
        _assert_value_equal(sub, w, g, f"{path}[{i}]")


def _seed(typename: str) -> int:
    return zlib.crc32(typename.encode())


def test_every_interface_package_is_under_test() -> None:
    # A package that failed to load would make the parametrised tests vanish silently.
    assert len(interfaces.registered_types("px4_msgs")) >= 13
    assert len(interfaces.registered_types("quadmission_interfaces")) >= 40
    assert "action_msgs/srv/CancelGoal_Request" in TYPES
    assert "action_msgs/srv/CancelGoal_Response" in TYPES


@pytest.mark.parametrize("extreme", [False, True], ids=["random", "extreme"])
@pytest.mark.parametrize("typename", TYPES)
def test_roundtrip(typename: str, extreme: bool) -> None:
    msg = Filler(_seed(typename), extreme=extreme).message(typename)
    interfaces.validate(msg)

    data = interfaces.serialize(msg)
    assert data[:4] == CDR_LE_HEADER, f"{typename}: not little-endian XCDR1: {data[:4].hex()}"

    back = interfaces.deserialize(data, typename)
    assert interfaces.messages_equal(msg, back)
    assert_fields_equal(typename, msg, back)
    assert interfaces.serialize(back) == data


def _assert_not_default(typename: str, msg: Any, path: str) -> None:
    default = interfaces.new(typename)
    for name, node in _fielddefs(typename):
        want, base, where = getattr(msg, name), getattr(default, name), f"{path}.{name}"
        if node[0] == Nodetype.NAME:
            _assert_not_default(node[1], want, where)
        elif isinstance(want, np.ndarray):
            assert want.size > 0 and not np.array_equal(want, base), where
            assert np.all(want != 0), f"{where} has zero elements: {want}"
        elif isinstance(want, list):
            assert len(want) > 0, where
            if node[1][0][0] == Nodetype.NAME:
                for i, item in enumerate(want):
                    _assert_not_default(node[1][0][1], item, f"{where}[{i}]")
        else:
            assert want != base, f"{where} is still its default {base!r}"


@pytest.mark.parametrize("typename", TYPES)
def test_filled_message_differs_from_default(typename: str) -> None:
    # Guards the filler: a field left at its default would not prove it survives the wire.
    _assert_not_default(typename, Filler(_seed(typename)).message(typename), typename)


def test_field_comparison_catches_a_changed_nested_field() -> None:
    # Guards the comparator: a wrong value deep inside a message must fail it.
    typename = "quadmission_interfaces/msg/MarkerDetectionArray"
    msg = Filler(3).message(typename)
    back = interfaces.deserialize(interfaces.serialize(msg), typename)
    back.detections[-1].pose.position.y += 1.0
    with pytest.raises(AssertionError, match=r"detections\[\d\]\.pose\.position\.y"):
        assert_fields_equal(typename, msg, back)
    back = interfaces.deserialize(interfaces.serialize(msg), typename)
    back.detections[0].corners_px = back.detections[0].corners_px.astype(np.float64)
    with pytest.raises(AssertionError, match="dtype"):
        assert_fields_equal(typename, msg, back)


def test_different_values_give_different_bytes() -> None:
    typename = "px4_msgs/msg/VehicleOdometry"
    a = Filler(1).message(typename)
    b = Filler(2).message(typename)
    assert interfaces.serialize(a) != interfaces.serialize(b)
    assert not interfaces.messages_equal(a, b)


def test_timesync_wire_layout_is_plain_cdr() -> None:
    # uint64 timestamp, uint8 seq, 7 bytes padding to align int64 tc1, int64 ts1.
    msg = interfaces.new(TIMESYNC_MSG, timestamp=123456789, seq=7, tc1=-5, ts1=2**40)
    data = interfaces.serialize(msg)
    assert data == CDR_LE_HEADER + struct.pack("<QB7xqq", 123456789, 7, -5, 2**40)


def test_offboard_control_mode_wire_layout() -> None:
    msg = interfaces.new("px4_msgs/OffboardControlMode", timestamp=42, velocity=True, attitude=True)
    data = interfaces.serialize(msg)
    assert data == CDR_LE_HEADER + struct.pack(
        "<Q7?", 42, False, True, False, True, False, False, False
    )


def test_nan_marks_invalid_px4_fields_and_survives() -> None:
    # PX4 uses NaN for "invalid / not controlled"; it must cross the link unchanged.
    nan = float("nan")
    msg = interfaces.new(
        "px4_msgs/TrajectorySetpoint",
        position=[nan, nan, -1.5],
        velocity=[0.5, nan, nan],
        yaw=nan,
    )
    back = interfaces.deserialize(interfaces.serialize(msg), "px4_msgs/TrajectorySetpoint")
    np.testing.assert_array_equal(back.position, np.array([nan, nan, -1.5], np.float32))
    np.testing.assert_array_equal(back.velocity, np.array([0.5, nan, nan], np.float32))
    assert np.isnan(back.yaw)
