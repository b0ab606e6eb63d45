"""Localisation faults flown into a hover: what the FCU and the flight stack do when the
visual odometry stops for good (the position-loss failsafe: down to the floor, never
into an obstacle), jumps, or comes late."""

from __future__ import annotations

import pytest

from interfaces.px4 import NavigationState
from sim.fault_spec import parse_fault
from sim.fcu.commander import FailsafeReason

from .hover import HOVER_Z_M, hover

pytestmark = pytest.mark.slow


def test_vio_lost_for_good_descends_to_the_floor_and_disarms() -> None:
    """Without a position the FCU cannot hold: after the estimator's vision timeout and
    COM_POS_FS_DELAY it descends, level, lands (the land detector's 8 s minimal-thrust
    rule, no velocity) and disarms, where it was: no drift into anything."""
    h = hover()
    at = h.t() + 0.5
    start = h.position()
    h.inject(parse_fault(f"vio_stop@{at}"))
    result = h.fly(25.0)
    assert result.crash is None, result.crash
    fw = h.sitl.firmware
    vision_s = fw.estimator.params.vision_timeout_us / 1e6
    delay_s = fw.commander.params.position_loss_delay_s
    descend = h.modes.first(NavigationState.DESCEND, at)
    assert descend is not None, h.modes.changes
    # the last sample fused was up to one vision period (plus the link) before the fault
    assert vision_s + delay_s - 0.1 <= descend - at <= vision_s + delay_s + 0.1
    st = fw.status
    assert st is not None and not st.state.armed, "landed and auto-disarmed"
    assert st.latest_disarming_reason.name == "AUTO_DISARM_LAND"
    end = h.position()
    assert end[2] < start[2] - HOVER_Z_M + 0.1, f"on the floor, z = {end[2]:.2f} m"
    drift = float(((end[:2] - start[:2]) ** 2).sum() ** 0.5)
    # the hold on a dead-reckoned estimate until the failsafe (~0.25 m here), then the
    # momentum kept while level (no position to stop it, as in PX4): well under a metre
    assert drift < 1.0, f"drifted {drift:.2f} m"


def test_a_short_vio_gap_resumes_offboard_where_it_was() -> None:
    """A gap longer than the loss delay starts the descent; the vision back, the FCU holds
    and returns to OFFBOARD (the mode the companion chose): the vehicle climbs back."""
    h = hover(seed=22)
    at = h.t() + 0.5
    h.inject(parse_fault(f"vio_stop@{at}:2"))
    result = h.fly(6.0)
    assert result.crash is None
    descend = h.modes.first(NavigationState.DESCEND, at)
    back = h.modes.first(NavigationState.OFFBOARD, at)
    assert descend is not None and back is not None and back > descend
    assert back <= at + 2.0 + 0.2, "offboard again as soon as the position is valid"
    st = h.sitl.firmware.status
    assert st is not None and st.failsafe_reason is FailsafeReason.NONE
    assert abs(h.position()[2] - HOVER_Z_M) < 0.3


def test_a_vio_jump_goes_unnoticed_and_moves_the_vehicle_by_the_jump() -> None:
    """Expected: nobody reacts (nothing checks the odometry's consistency). The FCU fuses
    the jumped poses and flies its estimate back to the hold: in truth the vehicle moves
    by minus the jump, in OFFBOARD all along, no failsafe."""
    h = hover(seed=23)
    at = h.t() + 0.5
    start = h.position()
    h.inject(parse_fault(f"vio_jump@{at},x=0.6,y=-0.4"))
    result = h.fly(6.0)
    assert result.crash is None
    assert [n for _, n, _ in h.modes.changes if _ >= at] == []  # never left OFFBOARD
    moved = h.position() - start
    assert abs(moved[0] + 0.6) < 0.1 and abs(moved[1] - 0.4) < 0.1, moved


def test_late_vio_within_the_estimator_buffer_is_ridden_out() -> None:
    """Expected: nobody reacts. 200 ms late, each pose is fused at its sample time (the
    estimator's buffer): the hold stays put."""
    h = hover(seed=24)
    at = h.t() + 0.5
    start = h.position()
    h.inject(parse_fault(f"vio_delay@{at}:4,delay_ms=200"))
    result = h.fly(6.0)
    assert result.crash is None
    assert [n for t, n, _ in h.modes.changes if t >= at] == []
    assert float(abs(h.position() - start).max()) < 0.15
