"""A faulted mission: the battery sags to CRITICAL during the exploration; the mission
must react by its error policy (LAND_NOW), and report.json's ``faults`` says so. One
short flight (26 s simulated), shared."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from quadmission.scenarios import ScenarioOptions
from quadmission.scenarios.mission.scenario import FAULT_SETTLE_S, fly_mission
from sim.fault_spec import parse_faults

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def report(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    out: Path = tmp_path_factory.mktemp("faulted")
    return fly_mission(ScenarioOptions(out=out, seed=0,
                                       faults=parse_faults(["battery_critical@25"])),
                       limit_s=60.0)


def test_battery_critical_during_explore_lands_now_at_once(report: dict[str, Any]) -> None:
    (fault,) = report["faults"]
    assert fault["kind"] == "battery_critical" and fault["at_s"] == 25.0
    assert fault["expected"] == "battery_critical: LAND_NOW"
    assert fault["observed"] == fault["expected"]
    assert 0.0 < fault["reaction_s"] < 1.5  # the FCU's battery status, then the watchdog
    states = [s["state"] for s in report["states"]]
    assert states[states.index("mission.explore") + 1] == "landing_now"


def test_the_landing_is_completed_and_the_fault_handled(report: dict[str, Any]) -> None:
    """Landing is the reaction: nothing else (e.g. a module error for the same battery)
    may take it over and leave the vehicle holding in the air."""
    (fault,) = report["faults"]
    assert fault["end_state"] in ("landed", "landed_on_start_pad")  # where it was: near start
    assert fault["handled"]
    states = [s["state"] for s in report["states"]]
    assert states[states.index("landing_now"):] == ["landing_now", "landed"]  # no HOLD after


@pytest.fixture(scope="module")
def aborted(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    out: Path = tmp_path_factory.mktemp("aborted")
    return fly_mission(ScenarioOptions(out=out, seed=0,
                                       faults=parse_faults(["operator_abort@25"])),
                       limit_s=60.0)


def test_a_run_a_fault_stops_flies_on_so_the_end_state_is_where_it_settles(
        aborted: dict[str, Any]) -> None:
    """HOLD stops the mission at once; the end state is judged after FAULT_SETTLE_S more,
    not at the instant the mission stopped (a drifting hold would look fine there)."""
    (fault,) = aborted["faults"]
    assert fault["observed"] == fault["expected"] == "operator_abort: HOLD"
    stopped_s = aborted["states"][-1]["t_s"]
    assert aborted["states"][-1]["state"] == "stopped"
    assert aborted["sim_time_s"] >= stopped_s + FAULT_SETTLE_S - 0.01
    assert fault["end_state"] == "holding" and fault["handled"]
