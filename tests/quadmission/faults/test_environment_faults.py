"""Environment faults flown into a hover: a ground robot driven across the vehicle's path
as it flies (``robot_across``). The wind gust is flown in the mission's benchmark."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pytest

from runtime import GoalStatus
from sim.fault_spec import parse_fault
from sim.scene import quad_state
from sim.world import Scene

from .hover import HOVER_Z_M, hover

pytestmark = pytest.mark.slow

TARGET_XY = (3.0, 4.5)  # m, the open floor (see test_localisation_faults.py)


@dataclass
class Track:
    """The vehicle's true position and the robots' (a world part, 20 Hz)."""

    name: str = "track"
    rate_hz: float = 20.0
    vehicle: list[np.ndarray] = field(default_factory=list)
    robots: list[np.ndarray] = field(default_factory=list)

    def update(self, t_ns: int, scene: Scene) -> None:
        self.vehicle.append(quad_state(scene.data, scene.index).position.copy())
        self.robots.append(scene.data.mocap_pos[list(scene.index.robot_mocap), :2].copy())


def test_a_robot_driven_across_the_path_is_flown_over() -> None:
    """Expected: nobody reacts. A robot drives across the reach's path 1.5 m ahead of the
    vehicle as it sets off: the vehicle, at the hover height, passes over it (0.25 m
    tall) and reaches its target, OFFBOARD all along; the robot did cross the path."""
    h = hover(seed=27)
    track = Track()
    h.sitl.extra_parts.append(track)
    at = h.t() + 0.3
    h.inject(parse_fault(f"robot_across@{at},ahead=1.5,beyond=1.5,speed=1"))
    result = h.pilot.reach_to(*TARGET_XY, HOVER_Z_M, limit_s=30.0)
    assert result.status == GoalStatus.SUCCEEDED
    assert h.fly(2.0).crash is None
    assert [n for t, n, _ in h.modes.changes if t >= at] == [], h.modes.changes
    (index,) = h.sitl.robots.drives
    vehicle = np.array(track.vehicle)
    robot = np.array(track.robots)[:, index]
    # the robot's closest approach to the vehicle's flown track, horizontally
    gaps = np.linalg.norm(vehicle[None, :, :2] - robot[:, None, :], axis=2)
    assert gaps.min() < 0.3, f"the robot came no closer than {gaps.min():.2f} m"
    assert float(np.linalg.norm(h.position()[:2] - TARGET_XY)) < 0.3
