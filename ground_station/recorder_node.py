"""The bag recorder: every discovered topic into a rosbag2 MCAP (``ros2 bag record``).

A thin node over :class:`~ground_station.bag.BagWriter` and
:class:`~ground_station.topic_tap.TopicTap`: each sample is written as received (CDR,
stamped with the node's clock), and the writer seals a chunk every ``flush_period_s``
of host time, so a killed run keeps all but the last moments. ``close()`` (or
``destroy_node``) writes the index.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ground_station.bag import BagWriter
from ground_station.errors import BagError
from ground_station.params import RecorderParams
from ground_station.topic_tap import TAP_QOS, TopicTap
from runtime import Node

NODE_NAME = "bag_recorder"


class BagRecorderNode(Node):
    """Records into the bag folder ``folder`` (created; it must not hold a bag yet), or the
    ``folder`` parameter's when started from a launch file."""

    def __init__(self, folder: Path | None = None, **kwargs: Any) -> None:
        super().__init__(NODE_NAME, **kwargs)
        self.params = self.declare_params(RecorderParams)
        if folder is None:
            if not self.params.folder:
                raise BagError(f"{NODE_NAME}: no bag folder; set its 'folder' parameter")
            folder = Path(self.params.folder)
        self.bag = BagWriter(folder, flush_period_s=self.params.flush_period_s)
        try:
            self.tap = TopicTap(self, include=self.params.include, exclude=self.params.exclude,
                                discovery_period_s=self.params.discovery_period_s,
                                on_new_topic=self._on_new_topic, on_sample=self.bag.write)
        except BaseException:
            self.bag.close()  # a refused pattern leaves a closed, empty bag
            raise

    def _on_new_topic(self, topic: str, msgtype: str) -> int:
        self.get_logger().debug("recording %s (%s)", topic, msgtype)
        return self.bag.add_topic(topic, msgtype, TAP_QOS)

    def close(self) -> None:
        """Stop listening and write the bag's summary and metadata.yaml."""
        self.tap.close()
        self.bag.close()

    def destroy_node(self) -> None:
        self.close()
        super().destroy_node()


__all__ = ["NODE_NAME", "BagRecorderNode"]
