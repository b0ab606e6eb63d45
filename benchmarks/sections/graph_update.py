"""The results page's section for `benchmarks/bench_graph_update.py`."""

from __future__ import annotations

from . import Json, Section
from ._markdown import host_line, pct, ratio, table


def _graph_update(d: Json) -> list[str]:
    lines = table(["figure", "value", "baseline", "ratio"], [
        ["map changes replayed", d["steps"], "-", "-"],
        ["changes that alter nothing that matters", pct(d["unchanged_share"]), "-", "-"],
        ["grid recomputed per change, median", pct(d["cubes_updated_share_median"], 1),
         "the whole grid", "-"],
        ["update time, median", f"{d['update_s_median'] * 1000:.0f} ms",
         f"full build {d['full_s_median'] * 1000:.0f} ms",
         f"{ratio(d['speedup_median'], 1)} less time (median of per-step ratios)"],
        ["the same graph as a full build on every step",
         "yes" if d["same_graph_every_step"] else "NO", "-", "-"],
    ])
    return [f"Arena `{d['arena']}` at {d['resolution_m']} m.", "", *lines,
            *host_line(d.get("host"))]


SECTIONS = {
    "graph_update": Section(
        "Voxel graph: update against full build",
        "The default arena's live map replayed cloud by cloud: the path finder updates the "
        "graph where the map changed instead of rebuilding it, and must get the graph a full "
        "build gives.",
        body=_graph_update),
}
