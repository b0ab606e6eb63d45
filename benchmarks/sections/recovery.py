"""The results page's section for `benchmarks/bench_recovery.py`."""

from __future__ import annotations

from . import Json, Results, Row, Section
from ._markdown import cm, dash, table


def _seconds(value: float | None) -> str:
    return dash(value if value is None else f"{value:.1f}")


def _landings(run: Json) -> str:
    if "landings" not in run:
        return "not scored (a ros2 launch)"
    return f"{run['inside']} of {run['landings']} inside; RMSE {cm(run['rmse_m'])}"


def _recovery(d: Json) -> list[str]:
    clean = d["clean"]
    rows = [["clean (the baseline)", "inproc", clean["result"], "-", "-",
             _seconds(clean["sim_s"]), "-", _landings(clean)]]
    rows += [[f"`{r['spec']}`", r["transport"], r["result"], _seconds(r["held_s"]),
              _seconds(r["resumed_s"]), _seconds(r["sim_s"]),
              "-" if r.get("lost_s") is None else f"{r['lost_s']:+.1f}",
              _landings(r)] for r in d["runs"]]
    return [f"The default arena, seed {d['seed']}, the whole mission each time.", ""] + table(
        ["fault", "transport", "result", "held at [s]", "resumed at [s]", "mission [s]",
         "against clean [s]", "landings"], rows) + [
        "", "Replay: " + "; ".join(f"`{r['replay']}`" for r in d["runs"]), ""]


def _headline(r: Results) -> list[Row]:
    d = r["recovery"]
    done = sum(run["result"] == "completed" for run in d["runs"])
    return [["a glitch that clears (FCU link 2 s in the take-off, VIO 3 s exploring, the "
             "navigation process killed and respawned over ros2): missions completed",
             f"{done} of {len(d['runs'])}", "target: all"]]


SECTIONS = {
    "recovery": Section(
        "What a glitch that clears costs",
        "Issue 39's three flights, each through the whole contest mission: in process a 2 s "
        "FCU link loss during the take-off and a 3 s VIO loss while exploring, beside the "
        "same seed's clean mission; under `--transport ros2` the navigation process killed "
        "mid-mission (SIGKILL) and respawned by the launcher. Each HOLDs, then RESUMEs; the "
        "mission time against the clean one is what the glitch cost (a moving robot found "
        "on a later sweep costs minutes, not the mission).",
        body=_recovery, headline=_headline),
}
