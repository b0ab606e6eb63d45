"""The results page's section for `benchmarks/bench_astar.py`."""

from __future__ import annotations

from . import Json, Results, Row, Section
from ._markdown import host_line, pct, ratio, span, table


def ratio_over_rounds(r: Json, key: str, digits: int = 2) -> str:
    """``r[key]`` as a ratio, with its range over the bench's rounds when it ran several
    (``r[key_without_median + "_rounds"]``: min, median, max)."""
    text = ratio(r[key], digits)
    rounds = r.get(key.removesuffix("_median") + "_rounds")
    if rounds and r.get("rounds", 1) > 1:
        text += f" ({span([rounds['min'], rounds['max']], digits)}x over {r['rounds']} rounds)"
    return text


def corner_ratio(r: Json) -> str:
    """networkx's time over ours corner to corner, with its range over the rounds."""
    c = r["corner_to_corner"]
    text = ratio(c["networkx_s"] / c["ours_s"], 0)
    rounds = r.get("per_round", [])
    if len(rounds) > 1:
        text += (f" ({span([x['corner_networkx_s'] / x['corner_ours_s'] for x in rounds], 0)}x"
                 f" over {len(rounds)} rounds)")
    return text


def _astar(d: Json) -> list[str]:
    rows = []
    for r in d["resolutions"]:
        rows.append([f"{r['resolution_m']} m", f"{r['free_cubes']:,} / {r['edges']:,}",
                     f"{r['queries']} ({r['networkx_queries']} with networkx)",
                     corner_ratio(r),
                     ratio_over_rounds(r, "speedup_vs_networkx_median", 0),
                     ratio_over_rounds(r, "time_ratio_vs_tcod_median"),
                     ratio(r["octile"]["speedup_vs_networkx_median"], 0),
                     ratio(r["octile"]["time_ratio_vs_tcod_median"], 3),
                     "yes" if r["same_cost_as_networkx"] else "NO"])
    lines = table(["resolution", "free cubes / edges", "queries",
                   "corner to corner: networkx time / ours", "per-query median: networkx / ours",
                   "ours / libtcod (median)", "octile: networkx / ours", "octile / libtcod",
                   "same cost as networkx"], rows)
    rows = [[f"{r['resolution_m']} m", f"{r['build_s_median']:.2f} s",
             f"{r['build_1m_points_s_median']:.2f} s", f"{r['networkx_graph_build_s']:.2f} s",
             pct(r["shortcut"]["waypoint_ratio_median"], 1),
             pct(1 - r["shortcut"]["length_ratio_median"], 1)] for r in d["resolutions"]]
    lines += table(["resolution", "graph build (cloud)", "graph build (1 M points)",
                    "networkx graph build", "waypoints kept by the shortcut",
                    "path shortened by"], rows)
    return [f"Cloud: {d['cloud']}, {d['cloud_points']:,} points.", "", *lines,
            *host_line(d.get("host"))]


def _headline(r: Results) -> list[Row]:
    astar = r["astar"]["resolutions"][0]
    return [[f"A* at {astar['resolution_m']} m, median query: networkx's time / ours",
             ratio_over_rounds(astar, "speedup_vs_networkx_median", 0),
             "networkx, same graph, same path cost"]]


SECTIONS = {
    "astar": Section(
        "A* on the voxel graph",
        "Our A* against networkx and libtcod on the same graph, built from the default "
        "arena's depth-camera cloud, corner to corner and on seeded random pairs. A ratio "
        "above 1x against networkx is how many times faster ours is; against libtcod, the "
        "share of its time ours takes. Times are wall clock: the per-query median is made "
        "of sub-millisecond queries and moves with the host's load more than the "
        "corner-to-corner figure; compare figures from one run only.",
        body=_astar, headline=_headline),
}
