"""The faults that act in the simulator, on the FCU link and in the FCU (issue 22).

:func:`install_faults` adds them to a :class:`~sim.fcu.sitl.Sitl`, scheduled in simulated
time; nothing here touches the companion:

- ``vio_stop``: the simulated visual odometry (:class:`~sim.vision.VisionPose`) stops
  publishing for the fault's duration;
- ``link_lost``: the serial link (:class:`~sim.fcu.link.Link`) loses every message, both
  ways, for the duration;
- ``battery_low`` / ``battery_critical``: the pack (and with it PX4's estimate) sags to a
  charge below ``BAT_LOW_THR`` / ``BAT_CRIT_THR`` of the FCU's battery parameters;
- ``wind_gust``: a horizontal force on the quadrotor's body (:class:`Gusts`, the
  actuation's :class:`~sim.world.Wind`), exactly over ``[at_s, at_s + duration_s)``.

The switches run in a world part (:class:`FaultSwitches`) at ``rate_hz``, before the
other parts of a tick: a fault starts at the first tick at or after its time (on time
when the time is a multiple of 10 ms, at 100 Hz). Kinds that act
elsewhere (the operator's) are left to the app. Same faults, same seed: same run.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from runtime.clock import NS_PER_S
from sim.fault_spec import Fault, FaultKind
from sim.fcu.battery import BatteryEstimatorParams
from sim.fcu.firmware import Firmware
from sim.fcu.link import Link
from sim.fcu.sitl import Sitl
from sim.vision import VisionPose
from sim.world import FloatArray, Scene, Wind

__all__ = ["SIM_KINDS", "FaultSwitches", "Gusts", "Switched", "install_faults", "sag_level"]

SIM_KINDS = frozenset({FaultKind.VIO_STOP, FaultKind.LINK_LOST, FaultKind.BATTERY_LOW,
                       FaultKind.BATTERY_CRITICAL, FaultKind.WIND_GUST})
"""The kinds this module injects."""


def _ns(t_s: float) -> int:
    return round(t_s * NS_PER_S)


@dataclass
class Gusts:
    """The wind a run had before (``base``) plus each gust's force while it blows."""

    base: Wind
    gusts: Sequence[Fault]

    def __post_init__(self) -> None:
        self._windows = []
        for g in self.gusts:
            heading = math.radians(g.value("direction_deg"))
            force = g.value("force")
            vector = np.array([force * math.cos(heading), force * math.sin(heading), 0.0])
            self._windows.append((_ns(g.at_s), _ns(g.end_s), vector))

    def force(self, t_ns: int) -> FloatArray:
        out = self.base.force(t_ns)
        for start, end, vector in self._windows:
            if start <= t_ns < end:
                out = out + vector
        return out


def sag_level(kind: FaultKind, params: BatteryEstimatorParams) -> float:
    """The charge a battery fault leaves by default: half way into its warning band."""
    if kind is FaultKind.BATTERY_LOW:
        return (params.crit_thr + params.low_thr) / 2.0
    if kind is FaultKind.BATTERY_CRITICAL:
        return (params.emergen_thr + params.crit_thr) / 2.0
    raise ValueError(f"{kind.value} is not a battery fault")


@dataclass(frozen=True)
class Switched:
    """A fault switched on (``on=True``) or off at ``t_s`` of simulated time."""

    t_s: float
    fault: Fault
    on: bool


@dataclass
class FaultSwitches:
    """The world part that switches the faults on and off at their times."""

    faults: Sequence[Fault]
    vision: VisionPose
    link: Link
    firmware: Firmware
    rate_hz: float = 100.0
    name: str = "faults"
    switched: list[Switched] = field(default_factory=list)
    """What was switched when (ground truth for the report)."""

    def __post_init__(self) -> None:
        events = []
        for f in self.faults:
            if f.kind in SIM_KINDS and f.kind is not FaultKind.WIND_GUST:
                events.append((_ns(f.at_s), True, f))
                if math.isfinite(f.end_s) and f.kind in (FaultKind.VIO_STOP,
                                                         FaultKind.LINK_LOST):
                    events.append((_ns(f.end_s), False, f))
        # in time order; at the same time an end before a start (windows are half-open)
        self._pending = sorted(events, key=lambda e: (e[0], e[1]))
        self._vio_down = 0  # overlapping outages: counted, so the first end does not
        self._link_down = 0  # restore what a later one still holds

    def update(self, t_ns: int, scene: Scene) -> None:
        while self._pending and self._pending[0][0] <= t_ns:
            _, on, fault = self._pending.pop(0)
            self._apply(fault, on)
            self.switched.append(Switched(t_ns / NS_PER_S, fault, on))

    def _apply(self, fault: Fault, on: bool) -> None:
        step = 1 if on else -1
        if fault.kind is FaultKind.VIO_STOP:
            self._vio_down += step
            self.vision.tracking = self._vio_down == 0
        elif fault.kind is FaultKind.LINK_LOST:
            self._link_down += step
            self.link.down = self._link_down > 0
        else:  # a battery sag
            fw = self.firmware
            params = fw.battery_estimator.params
            level = fault.value("remaining")
            if math.isnan(level):
                level = sag_level(fault.kind, params)
            fw.battery_model.sag_to(level)
            fw.battery_estimator.sag_to(level)


def install_faults(sitl: Sitl, faults: Sequence[Fault]) -> FaultSwitches | None:
    """Schedule the simulator's faults of ``faults`` in ``sitl``: the switches as an
    extra part, the gusts in the actuation's wind. None (and ``sitl`` untouched) when
    none of them acts in the simulator, so a run without faults is the run it was."""
    ours = [f for f in faults if f.kind in SIM_KINDS]
    if not ours:
        return None
    gusts = [f for f in ours if f.kind is FaultKind.WIND_GUST]
    if gusts:
        sitl.actuation.wind = Gusts(sitl.actuation.wind, gusts)
    switches = FaultSwitches(ours, sitl.vision, sitl.link, sitl.firmware)
    sitl.first_parts.append(switches)
    return switches
