"""A 4S LiPo pack under rotor load, and PX4's view of it (``BatteryStatus``).

Two parts, deterministic, no noise:

* :class:`BatteryModel`, the physics. The pack is ``cell_count`` cells in series, each an
  open-circuit voltage ``OCV(soc)`` (the LiPo table :data:`LIPO_OCV_TABLE`) behind an
  internal resistance ``r_cell``. Rotor thrusts ``T_i`` [N] draw electrical power through
  momentum theory (hover induced power) over a figure of merit and a motor/ESC efficiency::

      P_i    = T_i^1.5 / sqrt(2 rho A) / (figure_of_merit * drive_efficiency)   [W]
      P      = sum_i P_i + avionics_power_w                                    [W]
      V_oc   = cell_count * OCV(soc),  R = cell_count * r_cell
      P = V I = (V_oc - R I) I   =>   I = (V_oc - sqrt(V_oc^2 - 4 R P)) / (2 R)

  (the smaller root; beyond the pack's maximum power ``V_oc^2 / 4R`` the current is
  capped at ``V_oc / 2R``). The terminal voltage sags under load: ``V = V_oc - R I``.
  Charge is counted exactly: ``discharged_mah += I * dt_us / 3.6e6``.

* :class:`BatteryEstimator`, PX4's ``Battery`` library (``src/lib/battery``): it sees only
  the measured voltage and current, as the FCU does. Load-compensated cell voltage
  ``V/cells + r_internal_estimate * I`` mapped linearly between ``v_empty`` and
  ``v_charged`` gives a voltage-based state of charge; once initialised, the estimate is
  coulomb counting against ``capacity_mah`` pulled gently toward the voltage-based value
  (harder when the voltage is low), as PX4 does when the capacity is known. PX4 applies a
  weight of ``3e-4 * (1 - soc_v)`` per 100 Hz update; here the same pull is a rate
  ``voltage_weight_per_s * (1 - soc_v)`` so the result does not depend on the update rate.
  The warning level follows ``remaining`` against PX4's ``BAT_LOW_THR`` (0.15),
  ``BAT_CRIT_THR`` (0.07) and ``BAT_EMERGEN_THR`` (0.05); while armed it only rises (a
  voltage that recovers when the load drops does not clear a warning), disarmed it follows
  the estimate.

Parameters: ``config/fcu_battery.yaml`` (ROS 2 parameter-file shape). Pure module: numpy
and PyYAML, no runtime, no MuJoCo, no message classes; the node converts
:class:`BatteryStatusData` to ``px4_msgs/BatteryStatus``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from interfaces.px4 import BatteryWarning
from runtime.errors import ParameterError
from runtime.parameters import param, validate_parameters

__all__ = [
    "BATTERY_NODE_NAME",
    "LIPO_OCV_TABLE",
    "BatteryEstimator",
    "BatteryEstimatorParams",
    "BatteryMeasurement",
    "BatteryModel",
    "BatteryModelParams",
    "BatteryParams",
    "BatteryStatusData",
    "cell_ocv_v",
    "warning_for_remaining",
]

BATTERY_NODE_NAME = "fcu_battery"
"""The top-level key of the battery's section in a ROS 2 parameter file."""

_US_PER_S = 1_000_000
_US_PER_H = 3_600_000_000
_MAH_PER_AH = 1000.0

LIPO_OCV_TABLE: tuple[tuple[float, float], ...] = (
    (0.00, 3.27),
    (0.05, 3.61),
    (0.10, 3.69),
    (0.15, 3.71),
    (0.20, 3.73),
    (0.25, 3.75),
    (0.30, 3.77),
    (0.35, 3.79),
    (0.40, 3.80),
    (0.45, 3.82),
    (0.50, 3.84),
    (0.55, 3.85),
    (0.60, 3.87),
    (0.65, 3.91),
    (0.70, 3.95),
    (0.75, 3.98),
    (0.80, 4.02),
    (0.85, 4.08),
    (0.90, 4.11),
    (0.95, 4.15),
    (1.00, 4.20),
)
"""Open-circuit voltage of one LiPo cell [V] against state of charge [0..1], at rest."""

_OCV_SOC = np.array([soc for soc, _ in LIPO_OCV_TABLE])
_OCV_V = np.array([v for _, v in LIPO_OCV_TABLE])


# -- parameters ----------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class BatteryModelParams:
    """The pack and the power drawn by the rotors (see the module docstring)."""

    cell_count: int = param(4, unit="cells", range=(1, 14))
    """Cells in series (4S)."""
    capacity_mah: float = param(4000.0, unit="mAh", range=(0.0, 1e6), lo_open=True)
    """Charge from full to empty [mAh]."""
    internal_resistance_ohm: float = param(0.008, unit="Ohm", range=(0.0, 1.0))
    """Internal resistance of one cell [Ohm]; the pack's is ``cell_count`` times that."""
    initial_soc: float = param(1.0, range=(0.0, 1.0))
    """State of charge at the start [0..1]."""
    rotor_radius_m: float = param(0.127, unit="m", range=(0.0, 2.0), lo_open=True)
    """Propeller radius [m] (10" props), for the rotor disk area."""
    air_density_kg_m3: float = param(1.225, unit="kg/m^3", range=(0.0, 2.0), lo_open=True)
    """Air density [kg/m^3]."""
    figure_of_merit: float = param(0.6, range=(0.0, 1.0), lo_open=True)
    """Rotor figure of merit: ideal induced power over actual aerodynamic power."""
    drive_efficiency: float = param(0.75, range=(0.0, 1.0), lo_open=True)
    """Motor and ESC efficiency: shaft power over electrical power."""
    avionics_power_w: float = param(8.0, unit="W", range=(0.0, 1e3))
    """Power of the flight controller, companion computer and sensors [W], always drawn."""

    def __post_init__(self) -> None:
        validate_parameters(self)

    @property
    def pack_resistance_ohm(self) -> float:
        """Internal resistance of the pack [Ohm]."""
        return self.cell_count * self.internal_resistance_ohm


@dataclass(frozen=True, slots=True)
class BatteryEstimatorParams:
    """PX4's ``BAT1_*`` and ``BAT_*_THR`` parameters, for the FCU's estimate."""

    v_empty: float = param(3.6, unit="V", range=(2.5, 4.5))
    """``BAT1_V_EMPTY``: cell voltage [V] at 0 % under the load compensation."""
    v_charged: float = param(4.05, unit="V", range=(2.5, 4.5))
    """``BAT1_V_CHARGED``: cell voltage [V] at 100 %, > v_empty."""
    r_internal_ohm: float = param(0.008, unit="Ohm", range=(0.0, 1.0))
    """``BAT1_R_INTERNAL``: per-cell resistance [Ohm] used for load compensation."""
    low_thr: float = param(0.15, range=(0.12, 0.5))
    """``BAT_LOW_THR``: remaining fraction below which the warning is LOW."""
    crit_thr: float = param(0.07, range=(0.05, 0.5))
    """``BAT_CRIT_THR``: remaining fraction below which the warning is CRITICAL."""
    emergen_thr: float = param(0.05, range=(0.03, 0.5))
    """``BAT_EMERGEN_THR``: remaining fraction below which the warning is EMERGENCY."""
    current_filter_tau_s: float = param(2.0, unit="s", range=(0.0, 100.0))
    """Time constant [s] of the averaged current (``current_average_a``); 0: no filter."""
    voltage_weight_per_s: float = param(0.03, unit="1/s", range=(0.0, 10.0))
    """Pull of the voltage-based estimate on the fused one at 0 % [1/s] (PX4: 3e-4 @ 100 Hz)."""

    def __post_init__(self) -> None:
        validate_parameters(self)
        if self.v_charged <= self.v_empty:
            raise ParameterError(
                f"{self.v_charged!r} must be above v_empty = {self.v_empty!r} V",
                key="v_charged",
            )
        if not self.emergen_thr < self.crit_thr < self.low_thr:
            raise ParameterError(
                f"thresholds must satisfy emergen_thr < crit_thr < low_thr, got "
                f"{self.emergen_thr!r} < {self.crit_thr!r} < {self.low_thr!r}",
                key="crit_thr",
            )


@dataclass(frozen=True, slots=True)
class BatteryParams:
    """Everything in ``config/fcu_battery.yaml``."""

    model: BatteryModelParams = field(default_factory=BatteryModelParams)
    estimator: BatteryEstimatorParams = field(default_factory=BatteryEstimatorParams)


# -- the pack ------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class BatteryMeasurement:
    """What the power module measures: terminal voltage and current, and the truth behind it."""

    timestamp_us: int
    """FCU time of the measurement [us]."""
    voltage_v: float
    """Terminal voltage [V], sagging under load."""
    current_a: float
    """Current drawn [A], >= 0."""
    true_soc: float
    """True state of charge [0..1] (ground truth, for evaluation only)."""
    true_discharged_mah: float
    """Charge drawn since the start [mAh] (ground truth)."""


def cell_ocv_v(soc: float) -> float:
    """Open-circuit voltage [V] of one cell at state of charge ``soc`` (clipped to [0, 1])."""
    return float(np.interp(min(max(soc, 0.0), 1.0), _OCV_SOC, _OCV_V))


class BatteryModel:
    """The pack: ``step`` draws the power of the rotor thrusts for a time step."""

    def __init__(self, params: BatteryModelParams | None = None, start_us: int = 0) -> None:
        self.params = params if params is not None else BatteryModelParams()
        self._discharged_mah = (1.0 - self.params.initial_soc) * self.params.capacity_mah
        self._now_us = start_us
        self._last = self._measure(0.0)

    @property
    def soc(self) -> float:
        """True state of charge [0..1]."""
        return max(0.0, 1.0 - self._discharged_mah / self.params.capacity_mah)

    @property
    def last(self) -> BatteryMeasurement:
        """The latest measurement."""
        return self._last

    def power_w(self, rotor_thrusts_n: Sequence[float]) -> float:
        """Electrical power [W] drawn at these rotor thrusts (negative thrusts count as 0)."""
        p = self.params
        disk_area = math.pi * p.rotor_radius_m**2
        ideal_per_n15 = 1.0 / math.sqrt(2.0 * p.air_density_kg_m3 * disk_area)
        losses = p.figure_of_merit * p.drive_efficiency
        rotors = sum(max(float(t), 0.0) ** 1.5 for t in rotor_thrusts_n)
        return rotors * ideal_per_n15 / losses + p.avionics_power_w

    def current_a(self, power_w: float) -> float:
        """Current [A] that delivers ``power_w`` at the terminals at the present charge."""
        v_oc = self.params.cell_count * cell_ocv_v(self.soc)
        r = self.params.pack_resistance_ohm
        if power_w <= 0.0:
            return 0.0
        if r == 0.0:
            return power_w / v_oc
        disc = v_oc * v_oc - 4.0 * r * power_w
        if disc <= 0.0:  # beyond the pack's maximum power: it collapses to V_oc / 2
            return v_oc / (2.0 * r)
        return (v_oc - math.sqrt(disc)) / (2.0 * r)

    def _measure(self, current_a: float) -> BatteryMeasurement:
        v_oc = self.params.cell_count * cell_ocv_v(self.soc)
        voltage = max(v_oc - self.params.pack_resistance_ohm * current_a, 0.0)
        return BatteryMeasurement(
            timestamp_us=self._now_us,
            voltage_v=voltage,
            current_a=current_a,
            true_soc=self.soc,
            true_discharged_mah=self._discharged_mah
            - (1.0 - self.params.initial_soc) * self.params.capacity_mah,
        )

    def sag_to(self, soc: float) -> None:
        """A fault: the charge drops at once to ``soc`` (a failing cell); never raises it."""
        if not 0.0 <= soc <= 1.0:
            raise ValueError(f"soc: {soc!r} must be in [0, 1]")
        self._discharged_mah = max(self._discharged_mah, (1.0 - soc) * self.params.capacity_mah)
        self._last = self._measure(self._last.current_a)

    def step(self, dt_us: int, rotor_thrusts_n: Sequence[float]) -> BatteryMeasurement:
        """Draw the power of ``rotor_thrusts_n`` [N] for ``dt_us`` [us]; the measurement after.

        The current is computed at the start of the step (explicit Euler on the charge);
        the returned voltage is under that load at the charge left at the end.
        """
        if isinstance(dt_us, bool) or not isinstance(dt_us, int) or dt_us < 0:
            raise ValueError(f"dt_us: {dt_us!r} must be a non-negative integer number of us")
        current = self.current_a(self.power_w(rotor_thrusts_n))
        self._discharged_mah += current * _MAH_PER_AH * dt_us / _US_PER_H
        self._now_us += dt_us
        self._last = self._measure(current)
        return self._last


# -- PX4's estimate ------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class BatteryStatusData:
    """The fields of ``px4_msgs/BatteryStatus`` this simulation fills (others: defaults)."""

    timestamp_us: int
    connected: bool
    voltage_v: float
    current_a: float
    current_average_a: float
    discharged_mah: float
    remaining: float
    """Estimated remaining fraction [0..1]."""
    time_remaining_s: float
    """Time to empty at the averaged current [s]; NaN when the current is too small."""
    cell_count: int
    capacity_mah: float
    voltage_cell_v: tuple[float, ...]
    """Per-cell voltage [V] (the pack is balanced: all equal), ``cell_count`` entries."""
    internal_resistance_estimate: float
    """Per-cell internal resistance used for load compensation [Ohm]."""
    ocv_estimate: float
    """Load-compensated cell voltage [V]."""
    volt_based_soc_estimate: float
    """Voltage-based state of charge [0..1]."""
    warning: BatteryWarning


def warning_for_remaining(remaining: float, params: BatteryEstimatorParams) -> BatteryWarning:
    """PX4's ``determineWarning``: the level of a remaining fraction (below a threshold)."""
    if remaining < params.emergen_thr:
        return BatteryWarning.EMERGENCY
    if remaining < params.crit_thr:
        return BatteryWarning.CRITICAL
    if remaining < params.low_thr:
        return BatteryWarning.LOW
    return BatteryWarning.NONE


class BatteryEstimator:
    """PX4-style battery estimate from voltage and current (see the module docstring)."""

    _MIN_CURRENT_FOR_TIME_A = 0.1

    def __init__(
        self, params: BatteryEstimatorParams, cell_count: int, capacity_mah: float
    ) -> None:
        self.params = params
        self.cell_count = cell_count
        self.capacity_mah = capacity_mah
        self._last_us: int | None = None
        self._soc = 0.0
        self._discharged_mah = 0.0
        self._current_avg_a = 0.0
        self._warning = BatteryWarning.NONE

    def _volt_based_soc(self, voltage_v: float, current_a: float) -> tuple[float, float]:
        p = self.params
        cell_v = voltage_v / self.cell_count + p.r_internal_ohm * current_a
        soc = (cell_v - p.v_empty) / (p.v_charged - p.v_empty)
        return cell_v, min(max(soc, 0.0), 1.0)

    def sag_to(self, remaining: float) -> None:
        """A fault: the estimate follows the pack's sudden drop to ``remaining`` at once
        (as PX4's voltage-based estimate does on a sag); never raises it."""
        if not 0.0 <= remaining <= 1.0:
            raise ValueError(f"remaining: {remaining!r} must be in [0, 1]")
        self._soc = min(self._soc, remaining)

    def update(self, measurement: BatteryMeasurement, armed: bool) -> BatteryStatusData:
        """Fold in one measurement; the status to publish. Timestamps must not decrease."""
        p = self.params
        now = measurement.timestamp_us
        cell_v, soc_v = self._volt_based_soc(measurement.voltage_v, measurement.current_a)
        if self._last_us is None:  # initialise from the voltage, as PX4 does
            self._soc = soc_v
            self._current_avg_a = measurement.current_a
        else:
            if now < self._last_us:
                raise ValueError(
                    f"timestamp_us: {now} is before the previous measurement {self._last_us}"
                )
            dt_s = (now - self._last_us) / _US_PER_S
            used_mah = measurement.current_a * _MAH_PER_AH * dt_s / 3600.0
            self._discharged_mah += used_mah
            weight = 1.0 - math.exp(-p.voltage_weight_per_s * (1.0 - soc_v) * dt_s)
            self._soc = (1.0 - weight) * self._soc + weight * soc_v
            self._soc = max(self._soc - used_mah / self.capacity_mah, 0.0)
            alpha = (
                1.0
                if p.current_filter_tau_s == 0.0
                else 1.0 - math.exp(-dt_s / p.current_filter_tau_s)
            )
            self._current_avg_a += alpha * (measurement.current_a - self._current_avg_a)
        self._last_us = now

        level = warning_for_remaining(self._soc, p)
        self._warning = max(self._warning, level) if armed else level

        time_remaining = (
            self._soc * self.capacity_mah * 3.6 / self._current_avg_a
            if self._current_avg_a > self._MIN_CURRENT_FOR_TIME_A
            else math.nan
        )
        return BatteryStatusData(
            timestamp_us=now,
            connected=measurement.voltage_v > 0.0,
            voltage_v=measurement.voltage_v,
            current_a=measurement.current_a,
            current_average_a=self._current_avg_a,
            discharged_mah=self._discharged_mah,
            remaining=self._soc,
            time_remaining_s=time_remaining,
            cell_count=self.cell_count,
            capacity_mah=self.capacity_mah,
            voltage_cell_v=(measurement.voltage_v / self.cell_count,) * self.cell_count,
            internal_resistance_estimate=p.r_internal_ohm,
            ocv_estimate=cell_v,
            volt_based_soc_estimate=soc_v,
            warning=self._warning,
        )
