"""In-process delivery hands messages over; every type still survives CDR and a serializing
transport.

In one process publishers hand message objects over without CDR (runtime/transport.py),
so nothing in a normal run proves the types still serialize: this does, for every type,
filled with non-default values, and through a transport whose writers only take bytes
(as the ROS 2 transport's do).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from rosbags.interfaces import Nodetype

import interfaces
from interfaces.api import NUMPY_DTYPES, typestore
from runtime import DeterministicExecutor, Node
from runtime.transport import (
    Endpoint,
    InProcessTransport,
    MessageWriter,
    Reader,
    SampleCallback,
    Writer,
)

ALL_TYPES = interfaces.registered_types()


def _value(node: tuple[Any, Any], k: int) -> Any:
    kind, arg = node
    if kind == Nodetype.BASE:
        base, bound = arg
        if base in ("string", "wstring"):
            return "ab"[: bound or 2]
        if base == "bool":
            return True
        if base in ("float32", "float64"):
            return 1.5 + k
        return 1 + k % 100
    if kind == Nodetype.NAME:
        return _filled(arg, k + 1)
    sub, length = arg
    n = length if kind == Nodetype.ARRAY else min(length or 2, 2)
    if sub[0] == Nodetype.BASE and sub[1][0] in NUMPY_DTYPES:
        dtype = NUMPY_DTYPES[sub[1][0]]
        return (np.arange(n) % 2 == 0) if dtype is np.bool_ else (
            np.arange(1, n + 1) % 100).astype(dtype)
    return [_value(sub, k + i) for i in range(n)]


def _filled(typename: str, k: int = 0) -> Any:
    """A ``typename`` message whose every field differs from its default."""
    _, fields = typestore().fielddefs[typename]
    return interfaces.new(typename, **{name: _value(node, k + i)
                                       for i, (name, node) in enumerate(fields)})


def _equal(a: Any, b: Any) -> bool:
    if isinstance(a, np.ndarray):
        # values, not dtypes: rosbags reads a byte[] back as int8 where new() makes uint8
        return isinstance(b, np.ndarray) and np.array_equal(a, b)
    if isinstance(a, list):
        return len(a) == len(b) and all(_equal(x, y) for x, y in zip(a, b, strict=True))
    if hasattr(a, "__msgtype__"):
        names = typestore().fielddefs[a.__msgtype__][1]
        return a.__msgtype__ == b.__msgtype__ and all(
            _equal(getattr(a, n), getattr(b, n)) for n, _ in names)
    return bool(a == b)


def test_there_are_many_types() -> None:
    assert len(ALL_TYPES) > 100
    assert "px4_msgs/msg/VehicleOdometry" in ALL_TYPES


@pytest.mark.parametrize("typename", ALL_TYPES)
def test_every_type_round_trips_through_cdr(typename: str) -> None:
    msg = _filled(typename)
    back = interfaces.deserialize(interfaces.serialize(msg), typename)
    assert back is not msg
    assert _equal(back, msg), f"{typename} changed through CDR"
    assert not _equal(back, interfaces.new(typename)) or not typestore().fielddefs[typename][1]


class _BytesOnlyTransport:
    """The in-process channels behind writers that only take CDR bytes (like ROS 2's)."""

    def __init__(self) -> None:
        self._inner = InProcessTransport()
        self.samples: list[bytes] = []

    def create_writer(self, endpoint: Endpoint) -> Writer:
        inner = self._inner.create_writer(endpoint)
        samples = self.samples

        class _BytesWriter:
            def write(self, data: bytes, request_id: Any = None) -> None:
                assert isinstance(data, bytes)
                samples.append(data)
                inner.write(data, request_id)

            def matched_count(self) -> int:
                return inner.matched_count()

            def close(self) -> None:
                inner.close()

        return _BytesWriter()

    def create_reader(self, endpoint: Endpoint, on_sample: SampleCallback) -> Reader:
        return self._inner.create_reader(endpoint, on_sample)


@pytest.mark.parametrize("via", ["in-process", "bytes"])
def test_every_topic_type_is_delivered_equal_over_both_kinds_of_writer(via: str) -> None:
    transport = _BytesOnlyTransport() if via == "bytes" else InProcessTransport()
    ex = DeterministicExecutor(config_dir=None, transport=transport)  # type: ignore[arg-type]
    pub_node, sub_node = Node("pub", context=ex.context), Node("sub", context=ex.context)
    got: dict[str, Any] = {}
    sent: dict[str, Any] = {}
    for i, typename in enumerate(ALL_TYPES):
        topic = f"/t{i}"
        sub_node.create_subscription(typename, topic,
                                     lambda m, name=typename: got.__setitem__(name, m), 10)
        pub = pub_node.create_publisher(typename, topic, 10)
        assert isinstance(pub._writer, MessageWriter) == (via == "in-process")
        sent[typename] = _filled(typename)
        pub.publish(sent[typename])
    ex.spin_for(0.01)
    assert sorted(got) == sorted(ALL_TYPES)
    for typename, msg in sent.items():
        assert _equal(got[typename], msg), f"{typename} arrived changed over {via}"
        assert (got[typename] is msg) == (via == "in-process")
    if isinstance(transport, _BytesOnlyTransport):
        assert len(transport.samples) == len(ALL_TYPES)
