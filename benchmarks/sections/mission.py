"""The results page's section for `benchmarks/bench_mission.py`."""

from __future__ import annotations

from . import Json, Section
from ._markdown import dash, num, table


def _mission(d: Json) -> list[str]:
    runs = d["runs"]
    completed = [r for r in runs if r["result"] == "completed"]
    lines = table(["figure", "value", "baseline"], [
        ["missions completed, every landing inside its pad, no crash",
         f"{d['successes']} of {d['runs_done']}", f"target {d['target_successes']}"],
        ["the same with the fixes that followed it, with the defaults (see the note)",
         f"{d['final_code_successes']} of {d['runs_done']}", f"target {d['target_successes']}"],
        ["completed runs scoring their plan",
         f"{sum(r['score'] == r['planned'] for r in completed)} of {len(completed)}",
         "the operator's exact plan"],
        ["mean score / planned score, all runs", num(d["mean_score_ratio"], 3), "1.0"],
        ["mean score / the robot's whole table", num(d["mean_score_of_max"], 3),
         "later robots leave less time"],
        ["wall time per mission, p50 / max",
         f"{d['wall_time_s']['p50']:.0f} / {d['wall_time_s']['max']:.0f} s",
         f"{d['jobs']} missions at a time on the host"],
        ["real-time factor, p50", num(d["rtf_p50"]), "1.0 = real time"],
    ])
    lines += [f"Flown on {d['flown_on']}.", "", f"Final code: {d['final_code_note']}.", ""]
    lines += table(["seed", "arena", "result", "score / planned / greedy", "landings inside",
                    "simulated s", "RTF"],
                   [[r["seed"], r["arena"], r["result"] if r["ok"] else
                     f"{r['result']}: {r['reason']}",
                     f"{r['score']} / {dash(r['planned'])} / {dash(r['greedy'])}",
                     f"{r['inside']}/{r['landings']}", f"{r['sim_time_s']:.0f}", num(r["rtf"])]
                    for r in runs])
    lines += ["Re-flown after the fixes:", ""]
    lines += table(["seed", "with", "verdict", "robot found at"],
                   [[f["seed"], f["with"], f["verdict"], f"{f['robot_found_s']:.1f} s"]
                    for f in d["after_fixes"]])
    return lines


SECTIONS = {
    "mission": Section(
        "Contest mission on 20 random arenas",
        "The whole contest (`quadmission sim --scenario mission`) on seeded random arenas. "
        "Success: completed, every landing of the sequence inside its pad, no crash.",
        body=_mission),
}
