"""Flight behaviours (takeoff, reach, turn, land) as pure step functions."""

from flight_control.behaviours.base import (
    BEHAVIOUR_OUTCOMES,
    DISARM,
    NAV_LAND,
    OFFBOARD,
    Behaviour,
    CommandReply,
    CommandRequest,
    Observation,
    Setpoint,
    Step,
    arm_disarm,
)
from flight_control.behaviours.land import Land, LandFeedback
from flight_control.behaviours.reach import Reach, ReachFeedback, ReachTuning
from flight_control.behaviours.takeoff import Takeoff, TakeoffFeedback
from flight_control.behaviours.turn import Turn, TurnFeedback

__all__ = [
    "BEHAVIOUR_OUTCOMES",
    "DISARM",
    "NAV_LAND",
    "OFFBOARD",
    "Behaviour",
    "CommandReply",
    "CommandRequest",
    "Land",
    "LandFeedback",
    "Observation",
    "Reach",
    "ReachFeedback",
    "ReachTuning",
    "Setpoint",
    "Step",
    "Takeoff",
    "TakeoffFeedback",
    "Turn",
    "TurnFeedback",
    "arm_disarm",
]
