"""The simulator's faults act where they would on a drone, and only in their window: the
vision stops publishing, the link loses every message, the battery reports the sagged
level, the gust pushes the body. A SITL on the pad, nothing flying: each check reads the
part the fault acts on."""

from __future__ import annotations

import numpy as np
import pytest

from interfaces.px4 import BatteryWarning
from sim.fault_spec import FaultKind, parse_fault, parse_faults
from sim.faults import Gusts, install_faults, sag_level
from sim.fcu.link import LinkDirection
from sim.fcu.sitl import Sitl, build_sitl
from sim.world import NoWind


@pytest.fixture
def sitl() -> Sitl:
    return build_sitl(seed=3)


def _published_over(sitl: Sitl, seconds: float) -> int:
    before = sitl.vision.published
    sitl.run(seconds)
    return sitl.vision.published - before


def test_vio_stop_silences_the_vision_for_its_duration_only(sitl: Sitl) -> None:
    install_faults(sitl, parse_faults(["vio_stop@0.5:0.5"]))
    rate = sitl.vision.rate_hz
    assert _published_over(sitl, 0.5) == pytest.approx(0.5 * rate, abs=1)
    assert _published_over(sitl, 0.5) == 0
    assert _published_over(sitl, 0.5) == pytest.approx(0.5 * rate, abs=1)


def test_link_lost_drops_every_message_both_ways_in_its_window_only(sitl: Sitl) -> None:
    install_faults(sitl, parse_faults(["link_lost@0.5:0.5"]))

    def lost_over(seconds: float) -> tuple[int, int]:
        before = [sitl.link.counters(d) for d in LinkDirection]
        sitl.run(seconds)
        after = [sitl.link.counters(d) for d in LinkDirection]
        return (after[1].sent - before[1].sent, after[1].lost - before[1].lost)

    sent, lost = lost_over(0.5)
    assert sent > 0 and lost == 0  # the configured link loses nothing at this size
    sent, lost = lost_over(0.5)
    assert sent > 0 and lost == sent  # the FCU's telemetry all lost
    assert sitl.link.down
    sent, lost = lost_over(0.5)
    assert sent > 0 and lost == 0 and not sitl.link.down


@pytest.mark.parametrize(("kind", "warning"), [(FaultKind.BATTERY_LOW, BatteryWarning.LOW),
                                               (FaultKind.BATTERY_CRITICAL,
                                                BatteryWarning.CRITICAL)])
def test_a_battery_sag_is_what_the_fcu_reports(sitl: Sitl, kind: FaultKind,
                                               warning: BatteryWarning) -> None:
    install_faults(sitl, parse_faults([f"{kind.value}@0.5"]))
    sitl.run(0.4)
    battery = sitl.firmware.battery
    assert battery is not None and battery.warning is BatteryWarning.NONE
    assert battery.remaining > 0.5
    sitl.run(0.3)
    battery = sitl.firmware.battery
    level = sag_level(kind, sitl.firmware.battery_estimator.params)
    assert battery is not None and battery.warning is warning
    assert battery.remaining == pytest.approx(level, abs=0.01)
    assert sitl.firmware.battery_model.soc == pytest.approx(level, abs=0.001)


def test_a_battery_sag_to_a_given_level(sitl: Sitl) -> None:
    install_faults(sitl, parse_faults(["battery_low@0.1,remaining=0.13"]))
    sitl.run(0.3)
    assert sitl.firmware.battery is not None
    assert sitl.firmware.battery.remaining == pytest.approx(0.13, abs=0.01)


def test_a_gust_blows_in_its_window_only_with_its_force_and_direction() -> None:
    gusts = Gusts(NoWind(), [parse_fault("wind_gust@1:2,force=3,direction_deg=90")])
    assert np.array_equal(gusts.force(999_999_999), np.zeros(3))
    np.testing.assert_allclose(gusts.force(1_000_000_000), [0.0, 3.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(gusts.force(2_999_999_999), [0.0, 3.0, 0.0], atol=1e-12)
    assert np.array_equal(gusts.force(3_000_000_000), np.zeros(3))


def test_a_gust_pushes_the_body_in_the_simulator(sitl: Sitl) -> None:
    install_faults(sitl, parse_faults(["wind_gust@0:1,force=3,direction_deg=90"]))
    sitl.run(0.2)
    np.testing.assert_allclose(sitl.scene.views.quad_force, [0.0, 3.0, 0.0], atol=1e-12)
    sitl.run(1.0)
    assert np.array_equal(sitl.scene.views.quad_force, np.zeros(3))


def test_no_sim_fault_leaves_the_sitl_as_it_was(sitl: Sitl) -> None:
    wind = sitl.actuation.wind
    assert install_faults(sitl, parse_faults(["operator_abort@3"])) is None
    assert sitl.first_parts == [] and sitl.actuation.wind is wind


def test_the_switches_note_when_each_fault_went_on_and_off(sitl: Sitl) -> None:
    switches = install_faults(sitl, parse_faults(["vio_stop@0.2:0.3", "link_lost@0.25"]))
    assert switches is not None
    sitl.run(1.0)
    assert [(s.t_s, s.fault.kind, s.on) for s in switches.switched] == [
        (0.2, FaultKind.VIO_STOP, True), (0.25, FaultKind.LINK_LOST, True),
        (0.5, FaultKind.VIO_STOP, False)]
