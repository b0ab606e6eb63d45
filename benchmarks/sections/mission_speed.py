"""The results page's section for `benchmarks/bench_mission_speed.py`."""

from __future__ import annotations

from . import Json, Results, Row, Section
from ._markdown import cm, host_line, num, pct, table


def _make_sim_row(m: Json) -> list[str]:
    """`make sim`'s wall time (bench_mission_speed.py --make-sim-runs) against its target."""
    n = len(m["wall_s_runs"])
    verdict = ("every run under it, exit 0, with its bag" if m["every_run_under_target"]
               else "NOT every run under it, exit 0, with its bag")
    return ["`make sim` (with its bag), wall time"
            + (f", median of {n} runs" if n > 1 else ", one run"),
            f"{m['wall_s']:.1f} s (runs: {', '.join(f'{w:.1f}' for w in m['wall_s_runs'])} s;"
            f" exit codes {', '.join(str(c) for c in m['exit_codes'])})",
            f"under {m['target_s']:.0f} s: {verdict}"]


def _mission_speed(d: Json) -> list[str]:
    share, t = d["cpu_share"], d["thread_cpu_per_sim_s"]
    return table(["figure", "value", "baseline"], [
        ["real-time factor (simulated / wall seconds)"
         + (f", median of {len(d['rtf_runs'])} runs" if "rtf_runs" in d else ""),
         num(d["rtf_mission"]) + (f" (runs: {', '.join(num(r) for r in d['rtf_runs'])})"
                                  if "rtf_runs" in d else ""),
         f"bare world loop {num(d['rtf_bare_world'], 1)} (ratio "
         f"{num(d['ratio_mission_over_bare_world'], 3)})"],
        ["wall / CPU time (every thread) for the simulated time",
         f"{d['wall_s']:.0f} s / {d['cpu_s']:.0f} s for {d['sim_s']:.0f} s", "-"],
        ["busy samples per part: scanner, down camera, depth camera, mapping, FCU, other"
         + (" (py-spy, every Python thread)"
            if d.get("cpu_share_method", "").startswith("py-spy")
            else " (a sampler thread in the process: it sees the others mostly where they "
                 "let go of the GIL)"),
         ", ".join(pct(share[k]) for k in ("scanner", "down_camera", "depth_camera", "mapping",
                                          "fcu", "other")), "-"],
        ["CPU-s per simulated second by thread: main, Mesa's llvmpipe, the scan, the down "
         "and depth render threads",
         ", ".join(f"{t.get(k, 0.0):.3f}" for k in (
             "MainThread", "llvmpipe", "executor_work", "scene_renderer_down_camera",
             "scene_renderer_depth_camera"))
         + f" (all threads {d['cpu_per_sim_s']:.3f})", "-"],
        ["the mission: result, score, landings inside, touchdown RMSE / max",
         f"{d['result']}, {d['score']}/{d['max_score']}, {d['landings_inside']}/"
         f"{d['landings']}, {cm(d['touchdown_rmse_m'])} / {cm(d['touchdown_max_m'])}",
         "every landing inside, RMSE <= 3 cm"],
        *([_make_sim_row(m)] if (m := d.get("make_sim")) else []),
    ]) + host_line(None, d.get("load_before"))


def _headline(r: Results) -> list[Row]:
    m = r["mission_speed"]
    return [["contest mission, default arena, every node and both cameras: real-time factor",
             f"{num(m['rtf_mission'])} ({m['wall_s']:.0f} s wall for {m['sim_s']:.0f} s)",
             f"bare world loop {num(m['rtf_bare_world'], 0)}; target 5"]]


SECTIONS = {
    "mission_speed": Section(
        "Contest mission speed, default arena",
        "`quadmission sim` (default arena, seed 0, every node, both cameras with their 50 ms "
        "latency, the scanner off the callbacks' thread) in one process, with the bare world "
        "loop measured right after on the same host, and `make sim` itself timed. The CPU "
        "shares come from py-spy reading every thread's stack from outside the process.",
        body=_mission_speed, headline=_headline),
}
