"""The FCU's inputs across the link: polled at its dds_receive tick, or consumed on arrival."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

import interfaces
from interfaces.px4.topics import COMPANION_PUBLISHER_QOS, FMU_IN
from runtime import Node
from runtime.errors import ParameterError
from runtime.parameters import load_parameters
from sim.fcu.estimator import ESTIMATOR_NODE_NAME, EstimatorParams
from sim.fcu.firmware import ConsumedVision, FirmwareConfig
from sim.fcu.link import LinkParams
from sim.fcu.sitl import build_sitl

VISION = FMU_IN["vehicle_visual_odometry"]
SEND_PERIOD_S = 0.0033  # off the FCU's 2 ms dds_receive grid, so arrivals meet every phase
POLL_PERIOD_US = 2000  # dds_receive at 500 Hz on the default 500 Hz main loop


class _VisionSender(Node):
    """Publishes a vision sample every SEND_PERIOD_S, stamped with its send time [us]."""

    def __init__(self, variance: tuple[float, float, float] = (0.01, 0.01, 0.01),
                 **kwargs: Any) -> None:
        super().__init__("vision_sender", **kwargs)
        self.variance = np.array(variance, dtype=np.float32)
        self.pub = self.create_publisher(VISION.type, VISION.name, COMPANION_PUBLISHER_QOS)
        self.create_timer(SEND_PERIOD_S, self._send)

    def _send(self) -> None:
        now_us = self.now().nanoseconds // 1000
        nan3 = np.full(3, np.nan, dtype=np.float32)
        self.pub.publish(interfaces.new(
            VISION.type, timestamp=now_us, timestamp_sample=now_us, pose_frame=1,
            position=np.zeros(3, dtype=np.float32), q=np.array([1, 0, 0, 0], np.float32),
            velocity=nan3, angular_velocity=nan3, position_variance=self.variance,
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


def _variance_after_vision(variance: tuple[float, float, float]) -> list[float]:
    """The estimate's position variance after 0.2 s of vision samples of ``variance``."""
    sitl = build_sitl(seed=0, link=LinkParams.null())
    sitl.executor.add_node(_VisionSender(variance, context=sitl.executor.context))
    sitl.run(0.2)
    estimate = sitl.firmware.estimate
    assert estimate is not None and estimate.position_valid
    return estimate.position_variance_ned.tolist()


def test_vision_is_fused_with_its_largest_variance_and_nan_means_the_configured_one() -> None:
    largest = _variance_after_vision((0.04, 0.04, 0.04))
    assert _variance_after_vision((0.01, math.nan, 0.04)) == largest
    assert _variance_after_vision((0.01, 0.01, 0.01)) != largest
    std = load_parameters(EstimatorParams, ESTIMATOR_NODE_NAME).vision_position_std
    configured = _variance_after_vision((std**2,) * 3)  # sent as float32: equal to 1e-7
    assert _variance_after_vision((math.nan,) * 3) == pytest.approx(configured, rel=1e-6)
