"""The vehicle's ground truth (quadmission/vehicle/truth.py): the age of the external
vision its FCU fuses, as the FCU's estimator takes it across the link."""

from __future__ import annotations

import numpy as np

import interfaces
from interfaces.px4.topics import COMPANION_PUBLISHER_QOS, FMU_IN
from quadmission.vehicle.truth import FcuWatch, vision_figures
from runtime import Node
from sim.fcu.link import LinkParams
from sim.fcu.sitl import build_sitl

VISION = FMU_IN["vehicle_visual_odometry"]
AGE_S = 0.03  # how old each sample is when it is sent
POLL_S = 0.002  # the FCU takes its inputs at its 500 Hz dds_receive tick


class _LateVision(Node):
    """Sends a vision sample every 10 ms, sampled AGE_S before it is sent."""

    def __init__(self, **kwargs: object) -> None:
        super().__init__("late_vision", **kwargs)  # type: ignore[arg-type]
        self.pub = self.create_publisher(VISION.type, VISION.name, COMPANION_PUBLISHER_QOS)
        self.create_timer(0.01, self._send)

    def _send(self) -> None:
        now_us = self.now().nanoseconds // 1000
        if now_us < AGE_S * 1e6:
            return  # nothing sampled before the boot
        nan3 = np.full(3, np.nan, dtype=np.float32)
        self.pub.publish(interfaces.new(
            VISION.type, timestamp=now_us, timestamp_sample=now_us - round(AGE_S * 1e6),
            pose_frame=1, position=np.zeros(3, dtype=np.float32),
            q=np.array([1, 0, 0, 0], np.float32), velocity=nan3, angular_velocity=nan3,
            position_variance=np.full(3, 0.01, dtype=np.float32),
            orientation_variance=nan3, velocity_variance=nan3, quality=100))


def test_the_watch_records_the_age_of_each_vision_sample_the_fcu_fused() -> None:
    sitl = build_sitl(seed=0, link=LinkParams.null())  # FCU microseconds: simulated time
    watch = FcuWatch(sitl.firmware)
    sitl.executor.add_node(_LateVision(context=sitl.executor.context))
    sitl.run(0.5)
    ages = watch.vision_ages_s
    assert len(ages) >= 45  # 0.5 s at 100 Hz
    assert all(AGE_S <= a <= AGE_S + POLL_S for a in ages), ages  # sent, then the next tick
    figures = vision_figures(ages)
    assert figures["fused"] == len(ages)
    assert AGE_S * 1e3 <= figures["age_p50_ms"] <= figures["age_max_ms"] <= (AGE_S + POLL_S) * 1e3


def test_no_vision_has_no_age() -> None:
    assert vision_figures([]) == {"fused": 0, "age_p50_ms": None, "age_p99_ms": None,
                                  "age_max_ms": None}
