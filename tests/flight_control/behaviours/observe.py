"""Observations for behaviour tests: a vehicle that is where the test says."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from flight_control.behaviours import CommandReply, Observation
from flight_control.goal_checks import VehicleState
from interfaces.px4 import NavigationState

TICK_NS = 50_000_000  # 20 Hz, the setpoint rate


def observe(position: npt.ArrayLike = (0.0, 0.0, 1.0), *,
            velocity: npt.ArrayLike = (0.0, 0.0, 0.0), yaw: float = 0.0,
            armed: bool = True, offboard: bool = True, landed: bool = False,
            stale: bool = False, reply: CommandReply | None = None) -> Observation:
    nav = NavigationState.OFFBOARD if offboard else NavigationState.AUTO_LOITER
    vehicle = None if stale else VehicleState(
        connected=True, armed=armed, landed=landed, position_valid=True, battery_warning=0,
        offboard=offboard, nav_state=int(nav))
    return Observation(np.array(position, dtype=np.float64),
                       np.array(velocity, dtype=np.float64), yaw, vehicle, reply)
