"""Land detector: the three stages with their hysteresis, hover, takeoff, free fall."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from runtime.errors import ParameterError
from runtime.parameters import (
    config_path,
    load_parameters,
    parameter_fields,
    parameters_from_mapping,
)
from sim.fcu.land_detector import (
    LAND_DETECTOR_NODE_NAME,
    Hysteresis,
    LandDetectedData,
    LandDetector,
    LandDetectorInputs,
    LandDetectorParams,
)

MS = 1000
TICK_US = 20 * MS  # PX4's land detector runs at 50 Hz
PARAMS = load_parameters(LandDetectorParams, LAND_DETECTOR_NODE_NAME)
# PX4's MPC_THR_MIN and MPC_THR_HOVER defaults; the firmware passes its controller's and
# airframe's (tests/sim/fcu/test_firmware.py)
THRUST_MIN, THRUST_HOVER = 0.12, 0.5


def _detector(params: LandDetectorParams = PARAMS) -> LandDetector:
    return LandDetector(params, thrust_min=THRUST_MIN, thrust_hover=THRUST_HOVER)


def test_hysteresis_switches_only_after_the_request_held() -> None:
    h = Hysteresis(False, to_true_us=300, to_false_us=0)
    assert not h.update(True, 0)
    assert not h.update(True, 299)
    assert h.update(True, 300)
    assert not h.update(False, 301), "no delay from true to false"
    assert not h.update(True, 400)
    assert not h.update(False, 500)
    assert not h.update(True, 600), "an interrupted request starts over"
    assert h.update(True, 900)


def _descent_then_touchdown(
    detector: LandDetector, descent_us: int, ground_us: int
) -> tuple[list[LandDetectedData], int]:
    """Descend at 0.7 m/s (commanded 0.7 m/s), touch down, idle; outputs and touchdown time."""
    outs = []
    now = 0
    while now < descent_us:
        outs.append(
            detector.update(
                LandDetectorInputs(now, armed=True, thrust=0.45, vz=0.7, vz_setpoint=0.7)
            )
        )
        now += TICK_US
    touchdown = now
    while now < descent_us + ground_us:
        outs.append(
            detector.update(
                LandDetectorInputs(now, armed=True, thrust=0.13, vz=0.02, vz_setpoint=0.7)
            )
        )
        now += TICK_US
    return outs, touchdown


def test_a_descent_to_the_ground_reaches_landed_after_the_hysteresis() -> None:
    detector = _detector()
    outs, touchdown = _descent_then_touchdown(detector, 3_000_000, 2_000_000)
    flying = [o for o in outs if o.timestamp_us < touchdown]
    assert not any(o.landed or o.maybe_landed or o.ground_contact for o in flying[5:])

    def first(flag: str) -> int:
        return next(
            o.timestamp_us for o in outs if o.timestamp_us >= touchdown and getattr(o, flag)
        )

    stage = PARAMS.stage_time_us
    contact, maybe, landed = first("ground_contact"), first("maybe_landed"), first("landed")
    assert stage <= contact - touchdown <= stage + TICK_US
    assert stage <= maybe - contact <= stage + TICK_US
    assert stage <= landed - maybe <= stage + TICK_US
    assert 1_000_000 <= landed - touchdown <= 1_000_000 + 3 * TICK_US, "LNDMC_TRIG_TIME = 1 s"
    assert outs[-1].landed and outs[-1].at_rest


def _touchdown_sliding(
    vx: float, vy: float, v_xy_valid: bool = True, ground_us: int = 2_000_000
) -> list[LandDetectedData]:
    """A commanded descent, then on the ground with everything saying landed (idle thrust,
    no vertical speed, no rotation) but a horizontal velocity (vx, vy) [m/s, NED]."""
    detector = _detector()
    _, touchdown = _descent_then_touchdown(detector, 1_000_000, 0)
    return [
        detector.update(LandDetectorInputs(now, armed=True, thrust=0.13, vx=vx, vy=vy, vz=0.02,
                                           v_xy_valid=v_xy_valid, vz_setpoint=0.7))
        for now in range(touchdown, touchdown + ground_us, TICK_US)
    ]


def test_horizontal_movement_alone_keeps_it_from_landing() -> None:
    """Each axis under LNDMC_XY_VEL_MAX (1.5 m/s) but 1.2 m/s north and east is 1.7 m/s
    over the ground: sliding, not landed, however long it lasts."""
    assert max(1.2, 1.2) < PARAMS.xy_vel_max < math.hypot(1.2, 1.2)
    outs = _touchdown_sliding(1.2, 1.2)
    assert all(o.horizontal_movement for o in outs)
    assert not any(o.ground_contact or o.maybe_landed or o.landed for o in outs)
    assert not any(o.vertical_movement or o.rotational_movement for o in outs), \
        "only the horizontal condition may be what stops it"


@pytest.mark.parametrize(
    ("vx", "vy", "v_xy_valid"),
    [(1.5, 0.0, True), (0.0, -1.5, True), (1.2, 1.2, False)],
    ids=["at_the_limit_north", "at_the_limit_west", "velocity_invalid"],
)
def test_up_to_the_horizontal_limit_or_without_a_velocity_it_lands(
    vx: float, vy: float, v_xy_valid: bool
) -> None:
    """The limit itself is allowed (``|v_xy| <= xy_vel_max``), and without a valid
    horizontal velocity there is no horizontal movement (PX4)."""
    outs = _touchdown_sliding(vx, vy, v_xy_valid)
    assert not any(o.horizontal_movement for o in outs)
    assert outs[-1].landed


def test_sliding_after_landing_clears_landed_at_once() -> None:
    detector = _detector()
    outs, _ = _descent_then_touchdown(detector, 1_000_000, 2_000_000)
    assert outs[-1].landed
    out = detector.update(LandDetectorInputs(outs[-1].timestamp_us + TICK_US, armed=True,
                                             thrust=0.13, vx=2.0, vz=0.02, vz_setpoint=0.7))
    assert out.horizontal_movement
    assert not out.ground_contact and not out.maybe_landed and not out.landed
    assert not out.at_rest


def test_the_stages_come_in_order_and_never_skip() -> None:
    detector = _detector()
    outs, _ = _descent_then_touchdown(detector, 1_000_000, 2_000_000)
    for o in outs:
        assert not o.landed or o.maybe_landed
        assert not o.maybe_landed or o.ground_contact


@settings(max_examples=60, deadline=None)
@given(
    thrust=st.floats(0.3, 0.9),
    vz=st.floats(-0.2, 0.2),
    vz_setpoint=st.floats(-1.0, 1.0),
    climb_rate_control=st.booleans(),
)
def test_hover_never_reports_landed(
    thrust: float, vz: float, vz_setpoint: float, climb_rate_control: bool
) -> None:
    """Hover thrust is far above the low-thrust threshold, whatever the velocity."""
    detector = _detector()
    detector.update(LandDetectorInputs(0, armed=True, thrust=0.5, vz=-0.5))  # lifted off
    for k in range(1, 250):
        out = detector.update(
            LandDetectorInputs(
                k * TICK_US,
                armed=True,
                thrust=thrust,
                vz=vz,
                vz_setpoint=vz_setpoint,
                climb_rate_control=climb_rate_control,
            )
        )
        assert not out.landed and not out.maybe_landed and not out.ground_contact


def test_slow_low_thrust_flight_without_commanded_descent_is_not_ground_contact() -> None:
    """Under climb-rate control, low thrust and no motion is not enough: PX4 wants a descent."""
    detector = _detector()
    detector.update(LandDetectorInputs(0, armed=True, thrust=0.6, vz=-1.0))
    for k in range(1, 200):
        out = detector.update(
            LandDetectorInputs(k * TICK_US, armed=True, thrust=0.2, vz_setpoint=0)
        )
        assert not out.ground_contact


def test_disarmed_is_landed_and_takeoff_clears_it_at_once() -> None:
    detector = _detector()
    out = detector.update(LandDetectorInputs(0, armed=False, thrust=0.0))
    assert out.landed and out.maybe_landed and out.ground_contact
    out = detector.update(LandDetectorInputs(TICK_US, armed=True, thrust=0.7, vz=-0.5))
    assert not out.landed and not out.maybe_landed and not out.ground_contact


def test_freefall_after_its_trigger_time() -> None:
    detector = _detector()
    detector.update(LandDetectorInputs(0, armed=True, thrust=0.5, vz=-0.5))
    outs = [
        detector.update(
            LandDetectorInputs(k * TICK_US, armed=True, thrust=0.0, vz=3.0, specific_force_norm=0.3)
        )
        for k in range(1, 30)
    ]
    first = next(o.timestamp_us for o in outs if o.freefall)
    assert first - TICK_US == pytest.approx(300 * MS, abs=TICK_US)
    assert not any(o.landed for o in outs)


def test_parameters_are_checked() -> None:
    with pytest.raises(ParameterError, match=r"thrust_hover: 0\.4 must be above thrust_min = 0\.5"):
        LandDetector(PARAMS, thrust_min=0.5, thrust_hover=0.4)
    with pytest.raises(ParameterError, match=r"thrust_min: -0\.1 is outside \[0, 1\]"):
        LandDetector(PARAMS, thrust_min=-0.1, thrust_hover=0.4)
    with pytest.raises(ParameterError, match=r"thrust_hover: 1\.5 is outside \[0, 1\]"):
        LandDetector(PARAMS, thrust_min=0.1, thrust_hover=1.5)
    with pytest.raises(ParameterError, match=r"trigger_time_s.*\[0, 10\]"):
        replace(PARAMS, trigger_time_s=-1.0)


@pytest.mark.parametrize(("widening", "still_in_contact"), [(2.5, True), (1.0, False)])
def test_once_maybe_landed_the_vertical_speed_threshold_widens(
    widening: float, still_in_contact: bool
) -> None:
    detector = _detector(replace(PARAMS, z_vel_widening=widening))
    outs, _ = _descent_then_touchdown(detector, descent_us=1000 * MS, ground_us=2000 * MS)
    assert outs[-1].landed
    # 0.5 m/s is above z_vel_max (0.25) but within 2.5 times it
    out = detector.update(LandDetectorInputs(outs[-1].timestamp_us + TICK_US, armed=True,
                                             thrust=0.13, vz=0.5, vz_setpoint=0.7))
    assert out.ground_contact is still_in_contact


def test_the_thresholds_come_from_the_config_file() -> None:
    params = load_parameters(LandDetectorParams, LAND_DETECTOR_NODE_NAME)
    text = config_path(f"{LAND_DETECTOR_NODE_NAME}.yaml").read_text(encoding="utf-8")
    for name in ("z_vel_widening", "rotation_widening", "low_thrust_fraction",
                 "minimal_thrust_fraction", "descent_vz_threshold", "trigger_time_s"):
        assert f"    {name}: {getattr(params, name)!r} " in text, name


def test_the_config_file_is_the_only_source_of_the_values() -> None:
    # no code defaults that could disagree with the YAML (descent_vz_threshold once did:
    # 0.6 m/s in code, 0.15 m/s in the file the flights read)
    with_default = [f.name for f in parameter_fields(LandDetectorParams) if not f.required]
    assert with_default == [], f"code defaults beside fcu_land_detector.yaml: {with_default}"
    with pytest.raises(ParameterError, match=r"fcu_land_detector\.descent_vz_threshold: missing"):
        parameters_from_mapping(LandDetectorParams, LAND_DETECTOR_NODE_NAME, {
            LAND_DETECTOR_NODE_NAME: {"ros__parameters": {
                f.name: getattr(PARAMS, f.name) for f in parameter_fields(LandDetectorParams)
                if f.name != "descent_vz_threshold"}}})


def test_a_commanded_descent_above_the_configured_threshold_counts_as_landing() -> None:
    """In climb-rate control, ground contact needs a commanded descent faster than
    ``descent_vz_threshold`` (from the YAML)."""
    def contact(vz_setpoint: float) -> bool:
        detector = _detector()
        detector.update(LandDetectorInputs(0, armed=True, thrust=0.6, vz=-1.0))  # airborne
        outs = [detector.update(LandDetectorInputs(k * TICK_US, armed=True, thrust=0.13,
                                                   vz_setpoint=vz_setpoint))
                for k in range(1, 40)]
        return outs[-1].ground_contact

    threshold = PARAMS.descent_vz_threshold
    assert contact(2 * threshold)
    assert not contact(threshold), "at the threshold is not above it"


def test_without_a_vertical_velocity_minimal_thrust_for_more_than_8_s_is_landed() -> None:
    """PX4's fallback for flight without a vertical velocity (the position-loss descent):
    ground contact never holds, but minimal thrust without rotation for more than 8 s is
    maybe landed, then landed one stage later; a thrust above minimal restarts the wait."""
    detector = _detector()
    minimal = THRUST_MIN + 0.05 * (THRUST_HOVER - THRUST_MIN)
    hover_us = 2_000_000
    outs = []
    for now in range(0, 14_000_000, TICK_US):
        thrust = THRUST_HOVER if now < hover_us else minimal
        outs.append(detector.update(LandDetectorInputs(
            now, armed=True, thrust=thrust, vz=0.0, v_z_valid=False, v_xy_valid=False,
            vz_setpoint=0.7)))
    assert not any(o.ground_contact for o in outs), "no vertical velocity: no ground contact"
    maybe = next(o.timestamp_us for o in outs if o.maybe_landed)
    landed = next(o.timestamp_us for o in outs if o.landed)
    assert 8_000_000 < maybe - hover_us <= 8_000_000 + PARAMS.stage_time_us + 2 * TICK_US
    assert PARAMS.stage_time_us <= landed - maybe <= PARAMS.stage_time_us + TICK_US
    # a burst of thrust (still flying) starts the 8 s over
    detector = _detector()
    for now in range(0, 7_000_000, TICK_US):
        detector.update(LandDetectorInputs(now, armed=True, thrust=minimal, v_z_valid=False))
    detector.update(LandDetectorInputs(7_000_000, armed=True, thrust=THRUST_HOVER,
                                       v_z_valid=False))
    after = [detector.update(LandDetectorInputs(now, armed=True, thrust=minimal,
                                                v_z_valid=False))
             for now in range(7_020_000, 15_000_000, TICK_US)]
    assert not any(o.maybe_landed for o in after)
