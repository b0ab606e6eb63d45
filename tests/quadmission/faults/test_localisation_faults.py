"""Localisation faults flown into a hover: what the FCU and the flight stack do when the
visual odometry stops for good (the position-loss failsafe once the dead-reckoned
estimate's accuracy passes COM_POS_FS_EPH: down to the floor, within a metre of where it
was), jumps, or comes late."""

from __future__ import annotations

import pytest

from interfaces.px4 import NavigationState
from runtime import GoalStatus
from sim.fault_spec import parse_fault
from sim.fcu.commander import FailsafeReason
from sim.quadrotor import GRAVITY
from sim.world import Scene

from .hover import HOVER_Z_M, Hover, hover

pytestmark = pytest.mark.slow

# m, a hover point of the contest arena 1.25 m or more from every robot's body along its
# path (robot 14's corridor: y = 3.5 and x = 3.5) and 2 m or more from the walls (the
# vehicle descends there: at (3.0, 4.5), 0.5 m beside that corridor, a 0.36 m drift put it
# on robot 14 as it drove by)
OPEN_FLOOR_XY = (2.0, 5.0)


class DescendThrust:
    """A world part: the largest collective thrust the FCU's position loop asked for in
    DESCEND [N] (from its second sample there: the first may still be the loop's output
    of the mode before)."""

    name = "descend_thrust"
    rate_hz = 100.0

    def __init__(self, h: Hover) -> None:
        self.firmware = h.sitl.firmware
        self.largest = 0.0
        self._descending = False

    def update(self, t_ns: int, scene: Scene) -> None:
        out = self.firmware.position_out
        descending = self.firmware.nav_state is NavigationState.DESCEND
        if descending and self._descending and out is not None:
            self.largest = max(self.largest, out.collective_thrust)
        self._descending = descending


def _failover_s(h: Hover) -> float:
    """From the last vision sample to the position-loss descent: the estimator's vision
    timeout, then the commander's COM_POS_FS_DELAY."""
    fw = h.sitl.firmware
    return fw.estimator.params.vision_timeout_us / 1e6 + fw.commander.params.position_loss_delay_s


def test_vio_lost_for_good_descends_to_the_floor_and_disarms() -> None:
    """Without a position the FCU cannot hold: once its estimate's horizontal accuracy
    passes COM_POS_FS_EPH (before the vision timeout and COM_POS_FS_DELAY, together PX4's
    EKF2_NOAID_TOUT, would call it lost) it descends, level, lands (the land detector's
    8 s minimal-thrust rule, no velocity) and disarms. The hold on an IMU-only estimate
    drifts, but on the gyro with its bias calibrated at rest, decimetres, not metres."""
    h = hover()
    at = h.t() + 0.5
    start = h.position()
    h.inject(parse_fault(f"vio_stop@{at}"))
    thrust = DescendThrust(h)
    result = h.fly(25.0, thrust)
    assert result.crash is None, result.crash
    fw = h.sitl.firmware
    descend = h.modes.first(NavigationState.DESCEND, at)
    assert descend is not None, h.modes.changes
    # it cannot climb: never above PX4's fixed descent's thrust (the dead-reckoned
    # velocity once wound the loop up on the floor and lifted the vehicle off)
    ceiling = fw.quad.mass * (GRAVITY - fw.params.descend_acceleration)
    assert 0.0 < thrust.largest <= ceiling * (1 + 1e-9), (thrust.largest, ceiling)
    # the eph's growth in dead reckoning is the filter's variance alone: 1 m about 2.9 s
    # after the last sample (measured 2.96 s after the fault), before the 5 s failover
    limit = fw.commander.params.position_loss_eph_m
    eph = h.modes.eph_m[[t for t, _, _ in h.modes.changes].index(descend)]
    assert limit <= eph <= 1.05 * limit, f"descended at eph {eph:.3f} m"
    assert fw.estimator.params.vision_timeout_us / 1e6 < descend - at < _failover_s(h) - 1.0
    st = fw.status
    assert st is not None and not st.state.armed, "landed and auto-disarmed"
    assert st.latest_disarming_reason.name == "AUTO_DISARM_LAND"
    end = h.position()
    assert end[2] < start[2] - HOVER_Z_M + 0.1, f"on the floor, z = {end[2]:.2f} m"
    drift = float(((end[:2] - start[:2]) ** 2).sum() ** 0.5)
    # measured 0.54 m (seed 21; 0.7 to 1.2 m on seeds 22, 25, 26): held on the
    # dead-reckoned estimate until the failsafe, then the fall, level on that estimate (no
    # position to stop it, as in PX4). Before the gyro calibration at rest and the
    # gyro-only dead reckoning, 3.8 m: the tilt ran away under the hold.
    assert drift < 1.0, f"drifted {drift:.2f} m"
    assert h.speed() < 0.05, "at rest on the floor"


def test_a_vio_gap_shorter_than_ekf2_noaid_tout_is_ridden_out_in_offboard() -> None:
    """A 2 s gap: the estimate is invalid after the vision timeout, but the FCU waits
    out the rest of PX4's 5 s dead reckoning (EKF2_NOAID_TOUT) before it fails over:
    OFFBOARD all along, the hold kept on the IMU, no failsafe."""
    h = hover(seed=22)
    at = h.t() + 0.5
    start = h.position()
    h.inject(parse_fault(f"vio_stop@{at}:2"))
    result = h.fly(5.0)
    assert result.crash is None
    fw = h.sitl.firmware
    assert _failover_s(h) > 2.0 + 0.5, "the gap must end well before the failover"
    assert [n for t, n, _ in h.modes.changes if t >= at] == [], h.modes.changes
    st = fw.status
    assert st is not None and st.failsafe_reason is FailsafeReason.NONE
    assert float(abs(h.position() - start).max()) < 0.3, h.position() - start


def test_a_vio_gap_past_the_loss_delay_descends_then_resumes_offboard() -> None:
    """A gap longer than the vision timeout plus the loss delay starts the descent (the
    eph limit starts it sooner); the vision back, the FCU holds and returns to OFFBOARD
    (the mode the companion chose): the vehicle climbs back. Flown from the open floor,
    away from the walls the descent's drift could reach."""
    h = hover(seed=22)
    assert h.pilot.reach_to(*OPEN_FLOOR_XY, HOVER_Z_M).status == GoalStatus.SUCCEEDED
    at = h.t() + 0.5
    fw = h.sitl.firmware
    gap_s = _failover_s(h) + 1.0
    h.inject(parse_fault(f"vio_stop@{at}:{gap_s}"))
    result = h.fly(gap_s + 4.0)
    assert result.crash is None
    descend = h.modes.first(NavigationState.DESCEND, at)
    back = h.modes.first(NavigationState.OFFBOARD, at)
    assert descend is not None and back is not None and back > descend, h.modes.changes
    assert back <= at + gap_s + 0.2, "offboard again as soon as the position is valid"
    st = fw.status
    assert st is not None and st.failsafe_reason is FailsafeReason.NONE
    assert abs(h.position()[2] - HOVER_Z_M) < 0.3
    assert float(abs(h.position()[:2] - OPEN_FLOOR_XY).max()) < 0.3, "back over the hold"


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
