"""The mission through the real nodes over the SITL: pause and resume reach the running
exploration, and cutting the visual odometry for good holds the mission at once (no
automatic landing of its own); without a position the FCU's failsafe descends, and the
mission ends there, with the reason in the report. One short flight, shared.

The complete contest (every pad of the sequence landed) is ``make sim``'s run and the
benchmark's (``benchmarks/bench_mission.py``): minutes of simulated flight, too long here.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from quadmission.scenarios import ScenarioOptions
from quadmission.scenarios.mission.scenario import Act, Step, fly_mission

pytestmark = pytest.mark.slow

SCRIPT = (Step("mission.explore", 2.0, Act.PAUSE), Step("paused", 3.0, Act.RESUME),
          Step("mission.explore", 3.0, Act.CUT_VIO))


@pytest.fixture(scope="module")
def flight(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict[str, Any], Path]:
    out = tmp_path_factory.mktemp("mission")
    report = fly_mission(ScenarioOptions(out=out, seed=0), script=SCRIPT, limit_s=120.0)
    return report, out


def _states(report: dict[str, Any]) -> list[str]:
    return [s["state"] for s in report["states"]]


def test_the_script_was_played_in_order(flight: tuple[dict[str, Any], Path]) -> None:
    report, _ = flight
    assert [s["act"] for s in report["script"]] == ["pause", "resume", "cut_vio"]


def test_pause_holds_and_resume_goes_back_to_the_exploration(
        flight: tuple[dict[str, Any], Path]) -> None:
    states = _states(flight[0])
    assert states[:4] == ["idle", "preflight", "mission.takeoff", "mission.explore"]
    assert states[4:6] == ["paused", "mission.explore"]


def test_a_lost_visual_odometry_holds_the_mission_without_landing(
        flight: tuple[dict[str, Any], Path]) -> None:
    report, out = flight
    assert report["result"] == "stopped" and not report["ok"]
    # held at once; lost for good, the FCU's position-loss descent lands the vehicle
    # (the mission does not take off again from there)
    assert _states(report)[-3:] == ["mission.explore", "held", "landed"]
    assert report["reason"].startswith("localisation_lost in mission.explore")
    assert "landed the vehicle while held" in report["reason"]
    assert not any(s.startswith(("returning", "landing_now")) for s in _states(report))
    assert report["landings"] == [] and not report["crashed"]
    cut_s = report["script"][2]["t_s"]
    held_s = report["states"][-2]["t_s"]
    assert 0.0 < held_s - cut_s < 2.0  # at once: the FCU's vision timeout, then the hold
    on_disk = json.loads((out / "report.json").read_text())
    assert on_disk["reason"] == report["reason"]
    for name in report["pictures"].values():
        assert (out / name).stat().st_size > 0
