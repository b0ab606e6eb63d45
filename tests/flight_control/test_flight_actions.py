"""The motion actions' goal handling, alone: what a goal starts."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

import interfaces
from flight_control.behaviours import Reach, Setpoint
from flight_control.flight_actions import REACH, reach
from flight_control.params import FlightControlParams
from runtime.parameters import load_parameters
from tests.flight_control.behaviours.observe import observe


def test_a_reach_goal_starts_its_carrot_at_the_vehicles_speed_along_it() -> None:
    """A reach sent while the vehicle flies on from one it passed goes on at that speed."""
    params = load_parameters(FlightControlParams, "flight_control")
    action = reach(SimpleNamespace(params=params))  # type: ignore[arg-type]
    goal = interfaces.new(REACH.Goal, speed=1.0, radius=0.3, stop_at_target=False)
    goal.target.position.x, goal.target.position.y, goal.target.position.z = 5.0, 0.0, 1.5
    here = np.array([1.0, 0.0, 1.5])
    flying = action.start(goal, observe(here, velocity=(0.9, 0.3, 0.0)),
                          Setpoint.hold(here, 0.0))
    assert isinstance(flying, Reach)
    assert flying.progress.speed == pytest.approx(0.9)  # the part along the segment
    resting = action.start(goal, observe(here), Setpoint.hold(here, 0.0))
    assert isinstance(resting, Reach) and resting.progress.speed == 0.0
