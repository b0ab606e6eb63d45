"""Seed 000's measured link figures, the one place they are written.

Table 3 of seed 000 (MicroXRCE-DDS - ROS 2 row): the one-way latency between the companion
computer and the flight controller for a 115-byte message, measured where the receiver
consumes it (forward: when the FCU's estimator parses the vision sample; reverse: when the
companion node receives the IMU sample). The simulated link is calibrated to them and the
latency experiment is judged against them.
"""

from __future__ import annotations

from typing import NamedTuple

__all__ = ["TABLE3_MESSAGE_SIZE_BYTES", "TABLE3_TO_COMPANION", "TABLE3_TO_FCU", "LatencyFigure"]


class LatencyFigure(NamedTuple):
    """A one-way latency as a paper reports it: mean and standard deviation [us]."""

    mean_us: float
    sd_us: float


TABLE3_MESSAGE_SIZE_BYTES = 115
"""Message size of the seed 000 latency experiment (section 2.9) [bytes]."""
TABLE3_TO_FCU = LatencyFigure(mean_us=1329.0, sd_us=162.0)
"""Companion computer -> flight controller [us]."""
TABLE3_TO_COMPANION = LatencyFigure(mean_us=1752.0, sd_us=315.0)
"""Flight controller -> companion computer [us]."""
