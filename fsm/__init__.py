"""quadmission fsm layer: the contest mission as tables and a hierarchical state machine
(mission_table, mission_machine), the policy that drives it (mission_driver) and its node
(mission_node), and the operator's landing sequence (operator, operator_node)."""

from fsm.mission_machine import Mission, MissionConfig, MissionDriver, MissionEvent, Reply
from fsm.mission_table import ERROR_POLICY, ErrorCause, Phase, Reaction
from fsm.operator import Problem, Tour, solve_exact, solve_greedy

__all__ = ["ERROR_POLICY", "ErrorCause", "Mission", "MissionConfig", "MissionDriver",
           "MissionEvent", "Phase", "Problem", "Reaction", "Reply", "Tour", "solve_exact",
           "solve_greedy"]
