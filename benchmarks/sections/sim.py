"""The results page's section for `benchmarks/bench_sim.py`."""

from __future__ import annotations

from . import Json, Section
from ._markdown import ratio, table


def _sim(d: Json) -> list[str]:
    p = d["physics"]
    lines = table(["figure", "value", "baseline", "ratio"], [
        [f"world loop, physics steps per second ({p['physics_hz']} Hz)",
         f"{p['world_loop_steps_per_s']:,}", f"bare `mj_step` {p['bare_mj_step_steps_per_s']:,}",
         ratio(p["ratio_world_over_bare"])],
        ["world loop real-time factor, no camera", p["real_time_factor_no_camera"], "-", "-"],
    ])
    lines += table(["frame", "render + publish + deliver", "bare render", "ratio"],
                   [[c["size"], f"{c['render_publish_deliver_ms']} ms", f"{c['bare_render_ms']} ms",
                     ratio(c["ratio_ours_over_bare"])] for c in d["camera"]])
    return lines


SECTIONS = {
    "sim": Section(
        "World loop and camera cost",
        "The world loop's physics steps against bare `mj_step`, and a frame's cost against a "
        "bare render, in the same run.",
        body=_sim),
}
