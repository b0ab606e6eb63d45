"""Scenarios that ``quadmission sim --scenario NAME`` runs, each writing a report.

A scenario is a function of :class:`ScenarioOptions` that writes ``report.json`` (and
pictures) into ``options.out`` and returns the report. The registry maps names to them,
one module (or package) a scenario. Each report carries a one-line
``verdict`` for a person; progress goes to ``options.progress`` (the CLI prints it on
stderr).
"""

from __future__ import annotations

from collections.abc import Mapping

from quadmission.assembly.faults import SCENARIO_KINDS
from quadmission.scenarios.arena_tour import arena_tour
from quadmission.scenarios.mission.scenario import mission_scenario
from quadmission.scenarios.navigate import map_arena, navigate
from quadmission.scenarios.options import ARENA_NAME, Scenario, ScenarioOptions
from quadmission.scenarios.precision_landing.scenario import precision_landing
from quadmission.scenarios.square.flight import square
from sim.fault_spec import FaultKind

__all__ = ["ARENA_NAME", "DEFAULT_SCENARIO", "FAULTED_SCENARIOS", "SCENARIOS", "Scenario",
           "ScenarioOptions"]

SCENARIOS: dict[str, Scenario] = {
    "arena-tour": arena_tour,
    "map-arena": map_arena,
    "mission": mission_scenario,
    "navigate": navigate,
    "precision-landing": precision_landing,
    "square": square,
}
#: The scenarios that inject ``ScenarioOptions.faults`` (issue 22), each with the kinds it
#: takes (``quadmission.assembly.faults.SCENARIO_KINDS``); the others refuse them.
FAULTED_SCENARIOS: Mapping[str, frozenset[FaultKind]] = SCENARIO_KINDS
#: The most complete scenario there is; ``make sim`` runs it.
DEFAULT_SCENARIO = "mission"
