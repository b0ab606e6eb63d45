"""The results page's section for `benchmarks/bench_link.py`."""

from __future__ import annotations

from . import Json, Section
from ._markdown import num, table


def _link(d: Json) -> list[str]:
    rows = []
    for name, r in (("companion -> FCU", d["directions"]["to_fcu"]),
                    ("FCU -> companion", d["directions"]["to_companion"])):
        s, p = r["simulated_us"], r["paper_us"]
        rows.append([name, f"{s['mean']:.0f} +/- {s['sd']:.0f} us",
                     f"{s['p50']:.0f} / {s['p99']:.0f} us",
                     f"{p['mean']:.0f} +/- {p['sd']:.0f} us",
                     f"{num(r['ratio_mean_sim_over_paper'], 3)} / "
                     f"{num(r['ratio_sd_sim_over_paper'], 3)}",
                     f"{r['counters']['lost']} / {r['counters']['spikes']}"])
    lines = table(["direction", "link alone, mean +/- sd", "p50 / p99", "Table 3",
                   "ratio mean / sd", "lost / spikes"], rows)
    return [f"{d['samples']:,} samples of {d['size_bytes']} B every {d['period_us']:.0f} us on "
            "the idle line (no time-sync traffic queued ahead). Baseline: "
            f"{d['baseline']}.", "", *lines]


SECTIONS = {
    "link": Section(
        "FCU <-> companion link alone",
        "The serial link model without the experiment around it, against seed 000 Table 3.",
        body=_link),
}
