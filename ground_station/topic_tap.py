"""Raw taps on every topic a node can discover: what ``ros2 bag record -a`` and a
Foxglove bridge do. Samples arrive as CDR bytes, never decoded.

Discovery asks the transport for ``topic_names_and_types()`` (the in-process transport
and the DDS one offer it) every ``discovery_period_s`` of node time; topics named in
``topics`` are tapped as soon as they appear. Readers are BEST_EFFORT and VOLATILE, so
they match every writer (QoS request/offer rules) and never slow one down.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Any

from interfaces.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from runtime import Endpoint, Node
from runtime.transport import Reader

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
        self._include = re.compile(include)
        self._exclude = re.compile(exclude) if exclude else None
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
        listing = getattr(self._node.context.transport, "topic_names_and_types", None)
        if listing is None:
            return
        for name, msgtype in listing():
            if name in self._readers or not self._wanted(name):
                continue
            handle = self._on_new_topic(name, msgtype)

            def on_sample(data: bytes, _rid: Any, handle: Any = handle) -> None:
                self._on_sample(handle, self._node.get_clock().now().nanoseconds, data)

            self._readers[name] = self._node.context.transport.create_reader(
                Endpoint(name, msgtype, TAP_QOS), on_sample)
            self.topics[name] = msgtype

    def close(self) -> None:
        for reader in self._readers.values():
            reader.close()
        self._readers.clear()


__all__ = ["TAP_QOS", "TopicTap"]
