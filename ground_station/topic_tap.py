"""Raw taps on every topic a node can discover: what ``ros2 bag record -a`` and a
Foxglove bridge do. Samples are passed on as CDR bytes, never decoded (a message handed
over in-process is serialized first).

Discovery asks the transport for ``topic_names_and_types()`` when the tap starts and every
``discovery_period_s`` of node time; ``include`` and ``exclude`` choose among the topics
found. Readers are BEST_EFFORT and VOLATILE, so they match every writer (QoS
request/offer rules) and never slow one down.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Any

from ground_station.errors import GroundStationError
from interfaces.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from runtime import Endpoint, Node
from runtime.entity import sample_bytes
from runtime.transport import Reader


class TopicTapError(GroundStationError):
    """An ``include`` or ``exclude`` that is not a regular expression."""


#: What a tap requests: matches any writer.
TAP_QOS = QoSProfile(depth=100, history=HistoryPolicy.KEEP_LAST,
                     reliability=ReliabilityPolicy.BEST_EFFORT,
                     durability=DurabilityPolicy.VOLATILE)

NewTopic = Callable[[str, str], Any]  # (topic, msgtype) -> a handle given back with samples
Sample = Callable[[Any, int, bytes], None]  # (handle, t_ns, cdr)


class TopicTap:
    """Taps the topics ``node`` discovers whose names match ``include`` and not
    ``exclude`` (regular expressions, ``re.fullmatch``)."""

    def __init__(self, node: Node, *, include: str, exclude: str, discovery_period_s: float,
                 on_new_topic: NewTopic, on_sample: Sample) -> None:
        self._node = node
        self._include = _pattern("include", include)
        self._exclude = _pattern("exclude", exclude) if exclude else None
        self._on_new_topic = on_new_topic
        self._on_sample = on_sample
        self._readers: dict[str, Reader] = {}
        self.topics: dict[str, str] = {}
        self.discover()
        node.create_timer(discovery_period_s, self.discover)

    def _wanted(self, name: str) -> bool:
        if not self._include.fullmatch(name):
            return False
        return not (self._exclude and self._exclude.fullmatch(name))

    def discover(self) -> None:
        """Tap the topics that appeared since the last call."""
        for name, msgtype in self._node.context.transport.topic_names_and_types():
            if name not in self._readers and self._wanted(name):
                self._tap(name, msgtype)

    def _tap(self, name: str, msgtype: str) -> None:
        handle = self._on_new_topic(name, msgtype)

        def on_sample(data: Any, _rid: Any, handle: Any = handle) -> None:
            # in one process the sample is the message object itself, handed to us as it
            # is written (its publisher has just validated it): tap its CDR
            self._on_sample(handle, self._node.get_clock().now().nanoseconds,
                            bytes(sample_bytes(data, msgtype, check=False)))

        self._readers[name] = self._node.context.transport.create_reader(
            Endpoint(name, msgtype, TAP_QOS, node=self._node.get_fully_qualified_name()),
            on_sample)
        self.topics[name] = msgtype

    def close(self) -> None:
        for reader in self._readers.values():
            reader.close()
        self._readers.clear()


def _pattern(key: str, text: str) -> re.Pattern[str]:
    try:
        return re.compile(text)
    except re.error as e:
        raise TopicTapError(f"{key} {text!r}: not a regular expression ({e})") from None


__all__ = ["TAP_QOS", "TopicTap", "TopicTapError"]
