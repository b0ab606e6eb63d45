"""The FCU's inputs across the link: polled at its dds_receive tick, or consumed on arrival."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import interfaces
from interfaces.px4.topics import COMPANION_PUBLISHER_QOS, FMU_IN
from runtime import Node
from runtime.errors import ParameterError
from sim.fcu.firmware import ConsumedVision, FirmwareConfig
from sim.fcu.link import LinkParams
from sim.fcu.sitl import build_sitl

VISION = FMU_IN["vehicle_visual_odometry"]
SEND_PERIOD_S = 0.0033  # off the FCU's 2 ms dds_receive grid, so arrivals meet every phase
POLL_PERIOD_US = 2000  # dds_receive at 500 Hz on the default 500 Hz main loop


class _VisionSender(Node):
    """Publishes a vision sample every SEND_PERIOD_S, stamped with its send time [us]."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("vision_sender", **kwargs)
        self.pub = self.create_publisher(VISION.type, VISION.name, COMPANION_PUBLISHER_QOS)
        self.create_timer(SEND_PERIOD_S, self._send)

    def _send(self) -> None:
        now_us = self.now().nanoseconds // 1000
        nan3 = np.full(3, np.nan, dtype=np.float32)
        self.pub.publish(interfaces.new(
            VISION.type, timestamp=now_us, timestamp_sample=now_us, pose_frame=1,
            position=np.zeros(3, dtype=np.float32), q=np.array([1, 0, 0, 0], np.float32),
            velocity=nan3, angular_velocity=nan3, position_variance=np.full(3, 0.01, np.float32),
            orientation_variance=nan3, velocity_variance=nan3, quality=100))


def _consumed(event_driven: frozenset[str]) -> list[ConsumedVision]:
    """Vision samples as the FCU's estimator took them over an ideal link (delivery at the
    send time) and an ideal clock (FCU microseconds are simulated time)."""
    sitl = build_sitl(seed=0, link=LinkParams.null(),
                      firmware=FirmwareConfig(event_driven_inputs=event_driven))
    consumed: list[ConsumedVision] = []
    sitl.firmware.vision_observers.append(consumed.append)
    sitl.executor.add_node(_VisionSender(context=sitl.executor.context))
    sitl.run(0.2)
    assert len(consumed) >= 55  # 0.2 s / 3.3 ms
    return consumed


def test_a_polled_input_waits_for_the_next_dds_receive_tick() -> None:
    consumed = _consumed(frozenset())
    waits_us = [c.consumed_us - c.timestamp_us for c in consumed]
    assert all(0 <= w < POLL_PERIOD_US for w in waits_us), waits_us
    assert max(waits_us) > POLL_PERIOD_US // 2  # the arrivals meet the poll at many phases
    assert all(c.consumed_us % POLL_PERIOD_US == 0 for c in consumed)  # on the tick grid


def test_an_event_driven_input_is_consumed_when_it_arrives() -> None:
    consumed = _consumed(frozenset({"vehicle_visual_odometry"}))
    assert [c.consumed_us for c in consumed] == [c.timestamp_us for c in consumed]
    assert any(c.consumed_us % POLL_PERIOD_US for c in consumed)  # between ticks


def test_an_unknown_event_driven_input_is_refused_by_name() -> None:
    with pytest.raises(ParameterError, match="'vehicle_visual_odom' is not an /fmu/in topic"):
        build_sitl(seed=0, firmware=FirmwareConfig(
            event_driven_inputs=frozenset({"vehicle_visual_odom"})))
