"""Battery: discharge by current, sag under load, PX4 warning levels at their thresholds."""

from __future__ import annotations

import itertools
import math

import pytest

from interfaces.px4 import BatteryWarning
from runtime.errors import ParameterError
from runtime.parameters import load_parameters, parameters_from_mapping
from sim.fcu.battery import (
    BATTERY_NODE_NAME,
    BatteryEstimator,
    BatteryEstimatorParams,
    BatteryModel,
    BatteryModelParams,
    BatteryParams,
    BatteryStatusData,
    cell_ocv_v,
    warning_for_remaining,
)

STEP_US = 100_000  # 10 Hz
HOVER_N = (1.5 * 9.80665 / 4,) * 4  # the default 1.5 kg quad


def test_hover_power_and_current_are_plausible_for_the_default_quad() -> None:
    model = BatteryModel()
    power = model.power_w(HOVER_N)
    assert 150.0 < power < 230.0
    current = model.current_a(power)
    assert 9.0 < current < 16.0
    assert model.current_a(model.power_w((0.0,) * 4)) == pytest.approx(8.0 / (4 * 4.2), rel=0.01)


def test_current_grows_with_thrust() -> None:
    model = BatteryModel()
    currents = [model.current_a(model.power_w((t,) * 4)) for t in (0.0, 2.0, 4.0, 6.0, 8.0)]
    assert currents == sorted(currents) and len(set(currents)) == len(currents)


def test_discharge_counts_the_charge_drawn() -> None:
    model = BatteryModel()
    drawn_mah = 0.0
    for _ in range(600):  # one minute of hover
        m = model.step(STEP_US, HOVER_N)
        drawn_mah += m.current_a * STEP_US / 3.6e6
    assert m.true_discharged_mah == pytest.approx(drawn_mah, rel=1e-12)
    assert m.true_soc == pytest.approx(1.0 - drawn_mah / 4000.0, rel=1e-12)
    assert 150.0 < drawn_mah < 260.0  # 9-16 A for 60 s


def test_no_load_draws_only_the_avionics() -> None:
    idle = BatteryModel(BatteryModelParams(avionics_power_w=0.0))
    m = idle.step(60_000_000, (0.0,) * 4)
    assert m.current_a == 0.0 and m.true_soc == 1.0
    assert m.voltage_v == pytest.approx(4 * 4.2)


def test_voltage_sags_under_load_by_the_internal_resistance() -> None:
    params = BatteryModelParams(initial_soc=0.6)
    loaded, idle = BatteryModel(params), BatteryModel(params)
    hard = loaded.step(0, (8.0,) * 4)  # zero-length step: same charge, different load
    rest = idle.step(0, (0.0,) * 4)
    assert hard.voltage_v < rest.voltage_v - 0.5
    v_oc = 4 * cell_ocv_v(0.6)
    assert hard.voltage_v == pytest.approx(v_oc - params.pack_resistance_ohm * hard.current_a)
    assert hard.voltage_v * hard.current_a == pytest.approx(loaded.power_w((8.0,) * 4))


def test_voltage_falls_as_the_pack_empties() -> None:
    model = BatteryModel(BatteryModelParams(capacity_mah=200.0))
    volts = [model.step(STEP_US, HOVER_N).voltage_v for _ in range(500)]
    assert volts[-1] < volts[0] - 2.0
    assert all(b <= a + 1e-9 for a, b in itertools.pairwise(volts))


@pytest.mark.parametrize(
    ("remaining", "level"),
    [
        (0.50, BatteryWarning.NONE),
        (0.15, BatteryWarning.NONE),
        (0.149, BatteryWarning.LOW),
        (0.07, BatteryWarning.LOW),
        (0.069, BatteryWarning.CRITICAL),
        (0.05, BatteryWarning.CRITICAL),
        (0.049, BatteryWarning.EMERGENCY),
        (0.0, BatteryWarning.EMERGENCY),
    ],
)
def test_warning_levels_at_px4_thresholds(remaining: float, level: BatteryWarning) -> None:
    assert warning_for_remaining(remaining, BatteryEstimatorParams()) is level


def _discharge(capacity_mah: float = 150.0) -> list[BatteryStatusData]:
    model = BatteryModel(BatteryModelParams(capacity_mah=capacity_mah))
    estimator = BatteryEstimator(BatteryEstimatorParams(), 4, capacity_mah)
    out = [estimator.update(model.last, armed=True)]
    while out[-1].warning < BatteryWarning.EMERGENCY and len(out) < 10_000:
        out.append(estimator.update(model.step(STEP_US, HOVER_N), armed=True))
    return out


def test_a_full_discharge_raises_each_warning_as_remaining_crosses_its_threshold() -> None:
    statuses = _discharge()
    assert statuses[0].remaining == pytest.approx(1.0)
    assert statuses[-1].warning is BatteryWarning.EMERGENCY
    levels = [s.warning for s in statuses]
    assert levels == sorted(levels), "warnings only rise during a discharge"
    assert {BatteryWarning.LOW, BatteryWarning.CRITICAL} <= set(levels)
    for s in statuses:
        assert s.warning is warning_for_remaining(s.remaining, BatteryEstimatorParams())
    remaining = [s.remaining for s in statuses]
    assert all(b <= a for a, b in itertools.pairwise(remaining))
    assert statuses[-1].time_remaining_s < 30.0
    assert statuses[-1].discharged_mah == pytest.approx(0.95 * 150.0, rel=0.05)


def test_the_warning_holds_while_armed_and_follows_the_estimate_when_disarmed() -> None:
    params = BatteryEstimatorParams(voltage_weight_per_s=0.0, current_filter_tau_s=0.0)
    model = BatteryModel(BatteryModelParams(capacity_mah=150.0))
    estimator = BatteryEstimator(params, 4, 150.0)
    status = estimator.update(model.last, armed=True)
    while status.warning < BatteryWarning.LOW:
        status = estimator.update(model.step(STEP_US, HOVER_N), armed=True)
    # fresh estimator seeing the rested pack: the voltage says more than 15 % left
    rested = model.step(0, (0.0,) * 4)
    fresh = BatteryEstimator(BatteryEstimatorParams(), 4, 150.0)
    assert fresh.update(rested, armed=False).warning is BatteryWarning.NONE
    assert estimator.update(rested, armed=True).warning is BatteryWarning.LOW


def test_the_model_and_the_estimate_are_deterministic() -> None:
    assert _discharge() == _discharge()


def test_the_config_file_matches_the_code_defaults() -> None:
    assert load_parameters(BatteryParams, BATTERY_NODE_NAME) == BatteryParams(), (
        "the code defaults and config/fcu_battery.yaml disagree")


def test_the_config_file_loads_and_errors_name_the_key() -> None:
    params = load_parameters(BatteryParams, BATTERY_NODE_NAME)
    assert params.model.cell_count == 4
    assert params.estimator.low_thr == 0.15
    assert params.estimator.crit_thr == 0.07
    assert params.estimator.emergen_thr == 0.05
    with pytest.raises(ParameterError, match=r"fcu_battery\.model\.cells"):
        parameters_from_mapping(BatteryParams, BATTERY_NODE_NAME,
                                {"fcu_battery": {"ros__parameters": {"model": {"cells": 4}}}})
    with pytest.raises(ParameterError, match=r"estimator\.low_thr.*\[0.12, 0.5\]"):
        parameters_from_mapping(BatteryParams, BATTERY_NODE_NAME,
            {"fcu_battery": {"ros__parameters": {"estimator": {"low_thr": 0.9}}}}
        )
    with pytest.raises(ParameterError, match="emergen_thr < crit_thr < low_thr"):
        BatteryEstimatorParams(crit_thr=0.2, low_thr=0.15)
    with pytest.raises(ParameterError, match=r"capacity_mah.*\(0, 1e\+06\] mAh"):
        BatteryModelParams(capacity_mah=0.0)


def test_time_remaining_is_nan_without_load() -> None:
    model = BatteryModel(BatteryModelParams(avionics_power_w=0.0))
    estimator = BatteryEstimator(BatteryEstimatorParams(), 4, 4000.0)
    assert math.isnan(
        estimator.update(model.step(STEP_US, (0.0,) * 4), armed=False).time_remaining_s
    )
