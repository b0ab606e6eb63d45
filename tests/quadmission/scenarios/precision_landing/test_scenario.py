"""The precision-landing scenario through the whole stack (one episode: slow but one)."""

from __future__ import annotations

from pathlib import Path

import pytest

from quadmission.scenarios import SCENARIOS, ScenarioOptions
from quadmission.scenarios.precision_landing.scenario import run_landings, save_touchdowns, summary


@pytest.fixture(scope="module")
def landing(tmp_path_factory: pytest.TempPathFactory):
    options = ScenarioOptions(out=tmp_path_factory.mktemp("precision"), seed=0)
    arena = options.load_arena()
    landings = run_landings(options, arena, [arena.pad(1)])
    return options.out, landings


def test_the_scenario_is_registered():
    assert "precision-landing" in SCENARIOS


def test_lands_inside_the_pad_from_beside_it(landing):
    _, (d,) = landing
    assert d["landed"] and d["crash"] is None, d["message"]
    assert d["inside_pad"]
    assert d["touchdown_error_m"] < 0.05  # the RMSE target, for one landing
    # it started 0.3-1.0 m off the centre, so the landing had something to correct
    start_off = ((d["start_xy_m"][0] - 1.5) ** 2 + (d["start_xy_m"][1] - 1.5) ** 2) ** 0.5
    assert 0.3 <= start_off <= 1.0


def test_summary_and_picture(landing):
    out, landings = landing
    s = summary(landings)
    assert s["all_inside"] and not s["crashed"]
    assert s["rmse_m"] == pytest.approx(landings[0]["touchdown_error_m"])
    save_touchdowns(Path(out) / "t.png", "test", landings)
    assert (Path(out) / "t.png").stat().st_size > 1000
    assert (Path(out) / "arena.yaml").exists()
