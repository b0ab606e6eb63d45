"""Where a run ended, from its last true sample (``end_state``): at rest on the start pad,
just beyond its edge, in the air, or still moving.

The trajectories have a run's shapes (``TrajectoryRecorder.trajectory()``: time (N,),
position (N, 3) ENU, quaternion (N, 4), velocity (N, 3)): a landing's last two seconds at
50 Hz, ending where each case puts the vehicle. The arena is the contest's and the
resting height the quadrotor's, as the scenarios pass them.
"""

from __future__ import annotations

import numpy as np
import pytest

from quadmission.evaluation.faults import AT_REST_M_S, ON_GROUND_M, EndState, end_state
from sim.arena import PAD_SIZE, load_arena
from sim.quadrotor import QuadrotorParams
from sim.world import Crash, Trajectory

ARENA = load_arena()
REST = QuadrotorParams().leg_height  # m, body above the pad's top when standing on it
SX, SY, SZ = ARENA.takeoff_position
HALF = PAD_SIZE / 2.0


def ending_at(dx: float, dy: float, *, above: float = 0.0,
              velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> Trajectory:
    """A descent onto (start pad centre + (dx, dy)), ``above`` [m] over the resting height
    at the end, with ``velocity`` [m/s] at the last sample (1 m/s down before)."""
    n = 100
    t = np.arange(n) / 50.0
    position = np.column_stack([np.full(n, SX + dx), np.full(n, SY + dy),
                                SZ + REST + above + np.linspace(1.5, 0.0, n)])
    quaternion = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    speeds = np.tile([0.0, 0.0, -1.0], (n, 1))
    speeds[-1] = velocity
    return Trajectory(t, position, quaternion, speeds)


def judged(truth: Trajectory, crash: Crash | None = None) -> EndState:
    return end_state(truth, ARENA, REST, crash)


@pytest.mark.parametrize(("dx", "dy", "expected"), [
    (0.0, 0.0, EndState.LANDED_ON_START_PAD),
    (HALF - 0.01, 0.0, EndState.LANDED_ON_START_PAD),  # on the edge, still on the pad
    (-(HALF - 0.01), HALF - 0.01, EndState.LANDED_ON_START_PAD),  # a corner, inside
    (HALF + 0.01, 0.0, EndState.LANDED),  # 1 cm beyond the east edge
    (-(HALF + 0.01), 0.0, EndState.LANDED),  # ... the west edge
    (0.0, HALF + 0.01, EndState.LANDED),  # ... the north edge
    (0.0, -(HALF + 0.01), EndState.LANDED),  # ... the south edge
    (HALF - 0.01, -(HALF + 0.01), EndState.LANDED),  # inside along x, beyond along y
])
def test_at_rest_on_the_ground_it_is_on_the_start_pad_only_within_its_edges(
        dx: float, dy: float, expected: EndState) -> None:
    assert judged(ending_at(dx, dy)) is expected


@pytest.mark.parametrize("velocity", [
    (AT_REST_M_S + 0.05, 0.0, 0.0),  # sliding east
    (0.0, -(AT_REST_M_S + 0.05), 0.0),  # sliding south
    (0.0, 0.0, -(AT_REST_M_S + 0.05)),  # still settling down
    (0.12, 0.12, 0.0),  # 0.17 m/s diagonally: each axis alone would be at rest
])
def test_a_vehicle_still_moving_is_flying_wherever_it_is(
        velocity: tuple[float, float, float]) -> None:
    for dx in (0.0, HALF + 0.01):  # on the start pad, just beyond its edge
        assert judged(ending_at(dx, 0.0, velocity=velocity)) is EndState.FLYING


def test_slower_than_the_rest_speed_it_is_at_rest() -> None:
    creeping = (AT_REST_M_S - 0.05, 0.0, 0.0)
    assert judged(ending_at(0.0, 0.0, velocity=creeping)) is EndState.LANDED_ON_START_PAD
    assert judged(ending_at(HALF + 0.01, 0.0, velocity=creeping)) is EndState.LANDED


@pytest.mark.parametrize(("above", "expected"), [
    (ON_GROUND_M - 0.02, EndState.LANDED_ON_START_PAD),  # standing a little high: down
    (ON_GROUND_M + 0.02, EndState.HOLDING),  # at rest in the air over the pad
    (1.0, EndState.HOLDING),
])
def test_at_rest_above_the_pad_it_is_holding(above: float, expected: EndState) -> None:
    assert judged(ending_at(0.0, 0.0, above=above)) is expected


def test_only_the_last_sample_counts_and_a_crash_overrides_everything() -> None:
    landed = ending_at(HALF + 0.01, 0.0)
    assert np.linalg.norm(landed.velocity[:-1], axis=1).min() > AT_REST_M_S  # moved before
    assert judged(landed) is EndState.LANDED
    crash = Crash(1.0, (SX, SY, SZ + REST), "touchdown at 2.1 m/s")
    assert judged(ending_at(0.0, 0.0), crash) is EndState.CRASHED
