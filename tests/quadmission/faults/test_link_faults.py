"""Link, clock and process faults flown into a hover: what the FCU and the companion's
flight stack do when the serial link is slow or lossy, the companion's clock jumps, or
the flight-control node dies."""

from __future__ import annotations

import pytest

from interfaces.px4 import NavigationState
from quadmission.assembly.faults import AppFaults
from sim.fault_spec import parse_fault
from sim.fcu.link import LinkDirection

from .hover import hover

pytestmark = pytest.mark.slow


def _held(h, at: float, start, tol_m: float) -> None:  # type: ignore[no-untyped-def]
    assert [n for t, n, _ in h.modes.changes if t >= at] == [], h.modes.changes
    assert float(abs(h.position() - start).max()) < tol_m, h.position() - start


def test_a_latency_spike_below_com_of_loss_t_is_ridden_out() -> None:
    """Expected: nobody reacts. 300 ms more each way for 3 s: the heartbeat still comes
    within COM_OF_LOSS_T, the setpoints late but steady: OFFBOARD all along, in place."""
    h = hover(seed=31)
    at, start = h.t() + 0.5, h.position()
    h.inject(parse_fault(f"latency_spike@{at}:3,latency_ms=300"))
    assert h.fly(5.0).crash is None
    _held(h, at, start, 0.2)


def test_a_burst_of_lost_packets_is_ridden_out() -> None:
    """Expected: nobody reacts. Half the messages lost both ways for 3 s: enough
    heartbeats and poses get through."""
    h = hover(seed=32)
    at, start = h.t() + 0.5, h.position()
    h.inject(parse_fault(f"packet_burst@{at}:3,loss=0.5"))
    assert h.fly(5.0).crash is None
    _held(h, at, start, 0.15)
    assert h.sitl.link.counters(LinkDirection.TO_FCU).lost > 0


def test_a_companion_clock_jump_is_followed_by_the_time_sync() -> None:
    """Expected: nobody reacts. The companion's clock (the XRCE agent's) jumps 2 s, 13 s
    after boot: the FCU's time-sync filter, not converged yet (PX4's convergence window
    is 500 exchanges), takes the jump in as skew and follows it; the hold stays put.
    Measured: 8 s on, the estimate has come 1.5 s of the 2."""
    h = hover(seed=33)
    at, start = h.t() + 0.5, h.position()
    h.inject(parse_fault(f"clock_jump@{at},offset_ms=2000"))
    assert h.fly(8.0).crash is None
    _held(h, at, start, 0.2)
    est = h.sitl.firmware._last_timesync_status
    assert est is not None
    assert abs(est.offset_us - est.observed_offset_us) < 1_000_000, "following the new offset"


def test_the_flight_control_node_stopping_is_the_fcus_offboard_loss_failsafe() -> None:
    """Expected: the FCU's failsafe. In process the executor stops running the node: its
    setpoint stream stops; after COM_OF_LOSS_T the FCU holds, then lands."""
    h = hover(seed=34)
    at = h.t() + 0.5
    h.sitl.extra_parts.append(
        AppFaults(h.sitl.executor, [parse_fault(f"node_stop@{at},name=flight_control")]))
    assert h.fly(12.0).crash is None
    hold = h.modes.first(NavigationState.AUTO_LOITER, at)
    land = h.modes.first(NavigationState.AUTO_LAND, at)
    assert hold is not None and land is not None
    loss = h.sitl.firmware.commander.params.offboard_loss_timeout_s
    assert loss <= hold - at <= loss + 0.3
    assert land > hold


def test_a_flight_control_node_restarted_within_the_hold_takes_the_vehicle_back() -> None:
    """With a duration the node comes back (its process respawned) as a fresh instance:
    it sees the vehicle flying in offboard with nobody streaming and holds where it is, so
    the FCU has its signal back within its failsafe hold and returns to OFFBOARD instead
    of landing."""
    h = hover(seed=34)
    at = h.t() + 0.5
    h.sitl.extra_parts.append(
        AppFaults(h.sitl.executor, [parse_fault(f"node_stop@{at}:3,name=flight_control")]))
    assert h.fly(12.0).crash is None
    hold = h.modes.first(NavigationState.AUTO_LOITER, at)
    assert hold is not None  # the loss was noticed ...
    back = h.modes.first(NavigationState.OFFBOARD, hold)
    assert back is not None and at + 3.0 <= back <= hold + 5.0  # ... and cleared
    assert h.modes.first(NavigationState.AUTO_LAND, at) is None
