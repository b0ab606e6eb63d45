"""The results page's section for `benchmarks/bench_scheduler.py`."""

from __future__ import annotations

from . import Json, Section
from ._markdown import host_line, ratio, table


def _scheduler(d: Json) -> list[str]:
    lines = [f"{d['benchmark']}; main loop {d['main_freq_hz']} Hz.", ""]
    for load in ("nominal", "heavy"):
        s = d[load]
        static = s["static"]
        title = load if load == "nominal" else f"heavy (costs x{s['cost_scale']:.0f})"
        lines += [f"**{title}**", ""]
        lines += table(["offsets", "peak functions per tick", "peak cost per tick",
                        "predicted overrun ticks per hyperperiod", "median overruns (run)",
                        "median tick max (run)"],
                       [[name, static[name]["peak_functions_per_tick"],
                         f"{static[name]['peak_cost_us_per_tick']:.0f} us",
                         static[name]["predicted_overrun_ticks_per_hyperperiod"],
                         s["runtime"][name]["median_overruns"] if name in s["runtime"] else "-",
                         f"{s['runtime'][name]['median_tick_max_us']:.0f} us"
                         if name in s["runtime"] else "-"]
                        for name in ("naive", "balanced", "balanced_unit_cost")])
        lines += [f"Peak cost naive / balanced {ratio(s['peak_cost_ratio_naive_over_balanced'])}; "
                  "peak functions naive / balanced (unit costs) "
                  f"{ratio(s['peak_functions_ratio_naive_over_balanced_unit_cost'])}.", ""]
    return [*lines, *host_line(d.get("host"))]


SECTIONS = {
    "scheduler": Section(
        "Static scheduler (seed 002): offsets",
        "The naive offsets of seed 002 against our balanced offsets, statically (functions "
        "and cost per tick over the hyperperiod) and running, with nominal and heavy costs.",
        body=_scheduler),
}
