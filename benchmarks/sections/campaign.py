"""The results page's section for `benchmarks/bench_campaign.py`."""

from __future__ import annotations

from . import Json, Section
from ._markdown import host_line, ratio, span, table, yes


def _campaign(d: Json) -> list[str]:
    one, two = d["runs_per_hour_one_worker"], d["runs_per_hour_two_workers"]
    rounds = d["ratio_2_over_1_rounds"]
    return table(["figure", "value", "baseline"], [
        ["missions per CPU-hour (the runs' own CPU time)",
         f"{d['missions_per_cpu_hour']:.0f}", "-"],
        ["runs per wall hour, 1 worker / 2 workers", f"{span(one, 0)} / {span(two, 0)}",
         "-"],
        ["2 workers against 1, throughput",
         ratio(d["ratio_2_over_1"]) + (f" ({span(rounds)}x over {len(rounds)} rounds)"
                                       if len(rounds) > 1 else ""),
         "2.00x on 2 free cores"],
        ["every run passed", yes(d["all_passed"]), "yes"],
    ]) + host_line(d.get("host"))


SECTIONS = {
    "campaign": Section(
        "Campaign throughput",
        "`quadmission campaign`'s runner on a local Dask cluster of 1 worker process and of "
        "2, the same short clean square flights (random arenas with the smallest squares, "
        "light and dark), the two alternated over rounds. Throughput is wall clock and "
        "moves with the host's load (recorded below); the ratio of each round is measured in "
        "the same minutes.",
        body=_campaign),
}
