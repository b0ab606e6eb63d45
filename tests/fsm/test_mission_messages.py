"""The machine's enums are the message constants the ground station reads."""

from __future__ import annotations

import interfaces
from fsm.mission_machine import EventKind, Severity
from fsm.mission_table import Phase

QM = "quadmission_interfaces/msg"


def _constants(typename: str, prefix: str) -> dict[str, int]:
    constants, _ = interfaces.describe(typename)
    return {c.name.removeprefix(prefix): int(c.value) for c in constants
            if c.name.startswith(prefix)}


def test_phases_event_kinds_and_severities_match_the_messages() -> None:
    assert {p.name: p.value for p in Phase} == _constants(f"{QM}/MissionState", "PHASE_")
    assert {k.name: k.value for k in EventKind} == _constants(f"{QM}/MissionEvent", "KIND_")
    assert {s.name: s.value for s in Severity} == _constants(f"{QM}/MissionEvent", "SEVERITY_")
