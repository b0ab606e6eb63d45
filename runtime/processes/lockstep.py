"""The lockstep's messages as bytes: ``/clock`` and the node processes' reports.

Both are ``rosgraph_msgs/msg/Clock``: a ``builtin_interfaces/Time`` (int32 seconds, uint32
nanoseconds), 12 bytes of CDR. They are the busiest messages of a launch over processes
(the simulator's ``/clock`` about every 2 ms of simulated time to every node process, a
report from each of them as often), so they are packed and read here with :mod:`struct`
instead of through the typestore (rosbags' serialiser and its checks cost about 20 us a
message; this, under one). A payload in another encoding (big-endian CDR from a foreign
publisher) is read through the typestore.
"""

from __future__ import annotations

import struct

import interfaces
from interfaces import graph
from runtime.clock import Time

__all__ = ["clock_cdr", "clock_ns"]

_NS_PER_S = 1_000_000_000
_CDR_LE = b"\x00\x01\x00\x00"  # encapsulation: plain CDR, little endian
_CLOCK = struct.Struct("<4siI")  # encapsulation, sec, nanosec


def clock_cdr(t_ns: int) -> bytes:
    """The CDR of a ``Clock`` message at ``t_ns`` nanoseconds (``t_ns`` >= 0)."""
    sec, nanosec = divmod(t_ns, _NS_PER_S)
    return _CLOCK.pack(_CDR_LE, sec, nanosec)


def clock_ns(data: bytes) -> int:
    """The time of a ``Clock`` message's CDR, in nanoseconds."""
    if len(data) == _CLOCK.size and data[:4] == _CDR_LE:
        _, sec, nanosec = _CLOCK.unpack(data)
        return sec * _NS_PER_S + nanosec
    return Time.from_msg(interfaces.deserialize(data, graph.CLOCK.type).clock).nanoseconds
