"""The flight controller's own clock against simulated time: a boot offset and a skew.

The FCU stamps its px4_msgs in microseconds since its own boot, counted by its own crystal;
simulated time (what the sim's ``/clock`` publishes) is nanoseconds since the simulation
started. The model, with ``t_sim`` in ns and the result in us::

    fcu_time_us = boot_offset_us + floor(t_sim_ns * (1 + skew_ppm * 1e-6) / 1000)

* ``boot_offset_us``: the FCU's uptime when the simulation starts (the FCU booted that
  long before sim time 0), so ``fcu_time_us(0) == boot_offset_us``.
* ``skew_ppm``: how fast the FCU clock runs against simulated time. Positive means the FCU
  clock runs fast: after 100 s of simulated time at +50 ppm it has counted 100 005 000 us.

The factor is held exactly as an integer number of parts per billion
(``skew_ppb = round(skew_ppm * 1000)``), so the arithmetic is integer only and exact::

    fcu_time_us = boot_offset_us + (t_sim_ns * (10**9 + skew_ppb)) // 10**12

The map is non-decreasing; its inverse :meth:`FcuClock.sim_time_ns` gives the first
simulated nanosecond at which the FCU clock reads a given microsecond. In PX4's time-sync
sign convention (``companion = fcu + offset``, ``offset = companion - fcu``) a companion
whose clock is simulated time sees ``offset_us = t_sim_us - fcu_time_us``, that is
``-(boot_offset_us + skew_ppm * 1e-6 * t_sim_us)`` (to the microsecond).

Pure module: no runtime, no MuJoCo.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

from runtime.parameters import param, validate_parameters

__all__ = [
    "BOOT_OFFSET_RANGE_US",
    "SKEW_RANGE_PPM",
    "FcuClock",
]

BOOT_OFFSET_RANGE_US = (0, 10**15)
"""Allowed ``boot_offset_us`` [us]: from 0 to about 31 years of FCU uptime."""
SKEW_RANGE_PPM = (-1000.0, 1000.0)
"""Allowed ``skew_ppm`` [ppm]; real crystals are within about +/-50 ppm."""

_PPB_PER_UNIT = 10**9  # parts per billion in a factor of 1
_NS_PER_US = 1000


@functools.cache
def _rate_ppb(skew_ppm: float) -> int:
    """FCU nanoseconds per 10**9 simulated nanoseconds at ``skew_ppm``, the skew to the
    nearest ppb (kept: every FCU timestamp needs it)."""
    return _PPB_PER_UNIT + round(skew_ppm * 1000)


@dataclass(frozen=True, slots=True)
class FcuClock:
    """The FCU's clock as a function of simulated time (see the module docstring)."""

    boot_offset_us: int = param(unit="us", range=BOOT_OFFSET_RANGE_US)
    """FCU uptime at simulated time 0 [us], in ``BOOT_OFFSET_RANGE_US``."""
    skew_ppm: float = param(unit="ppm", range=SKEW_RANGE_PPM)
    """FCU clock rate error [ppm], positive = FCU runs fast; used to the nearest ppb."""

    def __post_init__(self) -> None:
        validate_parameters(self)

    @property
    def skew_ppb(self) -> int:
        """The skew actually applied, in integer parts per billion."""
        return _rate_ppb(self.skew_ppm) - _PPB_PER_UNIT

    @property
    def _rate_ppb(self) -> int:
        """FCU nanoseconds per 10**9 simulated nanoseconds (> 0 for any allowed skew)."""
        return _rate_ppb(self.skew_ppm)

    def fcu_time_us(self, sim_time_ns: int) -> int:
        """The FCU clock [us] at simulated time ``sim_time_ns`` [ns]; non-decreasing."""
        scaled = sim_time_ns * _rate_ppb(self.skew_ppm)  # FCU time in units of 1e-18 s
        return self.boot_offset_us + scaled // (_PPB_PER_UNIT * _NS_PER_US)

    def sim_time_ns(self, fcu_time_us: int) -> int:
        """The first simulated time [ns] at which the FCU clock reads ``fcu_time_us`` [us].

        ``fcu_time_us(sim_time_ns(t)) == t`` for every ``t``, and
        ``sim_time_ns(fcu_time_us(s)) <= s < sim_time_ns(fcu_time_us(s) + 1)``.
        """
        numerator = (fcu_time_us - self.boot_offset_us) * _PPB_PER_UNIT * _NS_PER_US
        return -((-numerator) // self._rate_ppb)  # ceil division

    @classmethod
    def ideal(cls) -> FcuClock:
        """The null clock: FCU microseconds are simulated time, no offset, no skew."""
        return cls(boot_offset_us=0, skew_ppm=0.0)
