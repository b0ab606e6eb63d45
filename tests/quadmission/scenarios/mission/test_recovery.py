"""Recovery through the real nodes over the SITL (issue 39): a fault that ends holds the
mission, which resumes where it was once the cause has been clear for the settle time.
One short flight per transient cause, the fault early, each stopped as soon as the
mission has gone on to its next phase (a whole mission is ``make sim``'s, too long here).
A module silent, then healthy again, is a node stopped and restarted in process (its
process respawned): the navigator's, while exploring."""

from __future__ import annotations

import logging
import re
from pathlib import Path
from typing import Any

import pytest

from quadmission.scenarios import ScenarioOptions
from quadmission.scenarios.mission.scenario import fly_mission
from sim.fault_spec import parse_faults

pytestmark = pytest.mark.slow


def _fly(out: Path, spec: str, limit_s: float) -> dict[str, Any]:
    return fly_mission(ScenarioOptions(out=out, seed=0, faults=parse_faults([spec])),
                       limit_s=limit_s)


def _hold(report: dict[str, Any]) -> tuple[list[str], float, float]:
    """The states from the one before the first ``held`` on, when it held and when it left
    ``held`` [s simulated]."""
    states = [(s["t_s"], s["state"]) for s in report["states"]]
    held = [name for _, name in states].index("held")
    return [name for _, name in states[held - 1:]], states[held][0], states[held + 1][0]


@pytest.fixture(scope="module")
def link_lost(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """The FCU link lost for 2 s during the take-off (seed 0: take-off from 6 s)."""
    return _fly(tmp_path_factory.mktemp("link_lost"), "link_lost@10:2", 25.0)


@pytest.fixture(scope="module")
def vio_lost(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """The visual odometry lost for 3 s while exploring (seed 0: from 21 s)."""
    return _fly(tmp_path_factory.mktemp("vio_lost"), "vio_stop@30:3", 45.0)


@pytest.fixture(scope="module")
def navigator_restarted(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """The navigator stopped at 30 s while exploring (seed 0: from 21 s), a fresh one
    started 4 s later (its process respawned)."""
    return _fly(tmp_path_factory.mktemp("navigator_restarted"),
                "node_stop@30:4,name=navigator", 48.0)


@pytest.fixture(scope="module")
def flight_control_restarted(tmp_path_factory: pytest.TempPathFactory
                             ) -> tuple[dict[str, Any], list[str]]:
    """Flight control stopped at 14 s, in the air after its take-off (seed 0: take-off
    from 6 s, the turns before the exploration), a fresh one started 4 s later; and what
    flight control said."""
    handler = _Lines()
    logger = logging.getLogger("quadmission.flight_control")
    level = logger.level
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)
    try:
        report = _fly(tmp_path_factory.mktemp("flight_control_restarted"),
                      "node_stop@14:4,name=flight_control", 40.0)
    finally:
        logger.removeHandler(handler)
        logger.setLevel(level)
    return report, handler.lines


class _Lines(logging.Handler):
    def __init__(self) -> None:
        super().__init__(logging.INFO)
        self.lines: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.lines.append(record.getMessage())


def test_a_flight_control_restarted_in_the_air_climbs_from_the_floor_not_from_its_hover(
        flight_control_restarted: tuple[dict[str, Any], list[str]]) -> None:
    # A fresh flight control never saw the take-off: the resumed take-off counts its
    # altitude from the floor under the vehicle. Counted from where it hovered (1.6 m) it
    # climbed to 3.1 m, near the ceiling, where no path could start (random arena 206).
    report, lines = flight_control_restarted
    names, _, _ = _hold(report)
    assert names[:4] == ["mission.takeoff", "held", "mission.takeoff", "mission.explore"], names
    takeoffs = [line for line in lines if "takeoff succeeded" in line]
    assert len(takeoffs) == 2, lines
    found = re.search(r"at ([\d.]+) m above the take-off point \(([-\d.]+), ([-\d.]+), "
                      r"([-\d.]+)\) m", takeoffs[1])
    assert found is not None, takeoffs[1]
    above, home_z = float(found.group(1)), float(found.group(4))
    assert home_z == 0.0  # the field's floor
    assert above == pytest.approx(1.5, abs=0.2)  # takeoff_altitude, not 1.5 m over 1.6 m
    assert report["final_state"] == "mission.explore" and not report["crashed"]


def test_a_link_loss_during_the_takeoff_holds_then_resumes_into_the_exploration(
        link_lost: dict[str, Any]) -> None:
    names, held_s, resumed_s = _hold(link_lost)
    assert names[:4] == ["mission.takeoff", "held", "mission.takeoff", "mission.explore"]
    assert 10.0 < held_s < 12.0  # /fcu/status silent for status_timeout_s
    assert resumed_s > 12.0  # not before the link is back and has settled
    (fault,) = link_lost["faults"]
    # whichever shows first: /fcu/status silent, or flight control's health saying the
    # FCU is not connected (both transient; the hold waits for every cause to clear)
    cause, _, then = fault["observed"].partition(": ")
    assert cause in ("offboard_lost", "module_error") and then == "HOLD, then RESUME"
    assert link_lost["final_state"] == "mission.explore" and not link_lost["crashed"]


def test_a_vio_loss_while_exploring_holds_then_explores_again(
        vio_lost: dict[str, Any]) -> None:
    names, held_s, resumed_s = _hold(vio_lost)
    assert names == ["mission.explore", "held", "mission.explore"]
    assert 30.0 < held_s < 31.5  # the FCU's vision timeout, then the watchdog
    assert resumed_s >= 33.0 + 2.0  # back at 33 s, then clear for the settle time
    (fault,) = vio_lost["faults"]
    assert fault["observed"] == "localisation_lost: HOLD, then RESUME"
    assert vio_lost["sim_time_s"] >= resumed_s + 5.0  # and it goes on exploring
    assert not vio_lost["crashed"]


def test_a_navigator_restarted_while_exploring_holds_then_explores_with_the_new_one(
        navigator_restarted: dict[str, Any]) -> None:
    names, held_s, resumed_s = _hold(navigator_restarted)
    assert names == ["mission.explore", "held", "mission.explore"]
    assert 33.0 < held_s < 33.5  # /navigator/health silent for silence_timeout_s (3 s)
    assert resumed_s >= 34.0 + 2.0  # the new one from 34 s, then OK for the settle time
    (fault,) = navigator_restarted["faults"]
    assert fault["observed"] == "module_silent: HOLD, then RESUME"
    # and it explores on: the new navigator took the resumed goal (a goal nobody served
    # would hold the mission in explore where it stopped, or fail it)
    assert navigator_restarted["sim_time_s"] >= resumed_s + 10.0
    assert navigator_restarted["final_state"] == "mission.explore"
    assert not navigator_restarted["crashed"]
