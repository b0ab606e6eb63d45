"""The results page's section for `benchmarks/bench_astar.py`."""

from __future__ import annotations

from . import Json, Results, Row, Section
from ._markdown import host_line, pct, ratio, span, table


def ratio_over_rounds(r: Json, key: str, digits: int = 2, inverse: bool = False) -> str:
    """``r[key]`` as a ratio, with its range over the bench's rounds when it ran several
    (``r[key_without_median + "_rounds"]``: min, median, max); ``inverse``: 1 / the ratio
    (libtcod's time over ours from ``time_ratio_vs_tcod``, ours over libtcod's)."""
    def flip(x: float) -> float:
        return 1 / x if inverse else x

    text = ratio(flip(r[key]), digits)
    rounds = r.get(key.removesuffix("_median") + "_rounds")
    if rounds and r.get("rounds", 1) > 1:
        ends = [flip(rounds["min"]), flip(rounds["max"])]
        text += f" ({span(ends, digits)}x over {r['rounds']} rounds)"
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


def host_speed(d: Json) -> str:
    """How fast the host was: the pure-Python reference loop timed in the same run
    (``host.reference_loop_s``, before and after), or the load when the run predates it."""
    h = d.get("host", {})
    if "reference_loop_s" in h:
        return (f"the host's pure-Python reference loop took "
                f"{span([1000 * s for s in h['reference_loop_s']], 0, 'ms')}")
    loads = h.get("load_average_1m", [])
    return ("this run predates the host-speed reference (`host.reference_loop_s`)"
            + (f"; 1-min load {span(loads, 1)} on {h['cpus']} CPUs" if loads else ""))


def _astar(d: Json) -> list[str]:
    rows = []
    for r in d["resolutions"]:
        rows.append([f"{r['resolution_m']} m", f"{r['free_cubes']:,} / {r['edges']:,}",
                     f"{r['queries']} ({r['networkx_queries']} with networkx)",
                     ratio_over_rounds(r, "time_ratio_vs_tcod_median", 1, inverse=True),
                     ratio_over_rounds(r["octile"] | {"rounds": r["rounds"]},
                                       "time_ratio_vs_tcod_median", 1, inverse=True),
                     ratio_over_rounds(r, "speedup_vs_networkx_median", 0),
                     corner_ratio(r),
                     ratio(r["octile"]["speedup_vs_networkx_median"], 0),
                     "yes" if r["same_cost_as_networkx"] else "NO"])
    lines = table(["resolution", "free cubes / edges", "queries",
                   "per-query median: libtcod's time / ours", "octile: libtcod / ours",
                   "per-query median: networkx / ours (host-dependent)",
                   "corner to corner: networkx / ours", "octile: networkx / ours",
                   "same cost as networkx"], rows)
    lines += ["The networkx ratios move with the host's speed, the libtcod ratios much less. "
              f"Host speed: {host_speed(d)}.", ""]
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
    d = r["astar"]
    astar = d["resolutions"][0]
    return [[f"A* at {astar['resolution_m']} m, median query: libtcod's time / ours",
             ratio_over_rounds(astar, "time_ratio_vs_tcod_median", 1, inverse=True)
             + "; networkx's / ours "
             + ratio_over_rounds(astar, "speedup_vs_networkx_median", 0)
             + f", host-dependent: {host_speed(d)}",
             "libtcod's C A* and networkx, same graph, same path cost"]]


SECTIONS = {
    "astar": Section(
        "A* on the voxel graph",
        "Our A* against libtcod (C) and networkx (pure Python) on the same graph, built from "
        "the default arena's depth-camera cloud, corner to corner and on seeded random "
        "pairs. Each ratio is the baseline's time over ours: above 1x, ours is faster. "
        "libtcod is the steady baseline. networkx slows more than ours when the host is "
        "slow, so its ratio moves with the host's speed, by up to 3x between a loaded host "
        "and an idle one: read it with the host's speed beside it. Times are wall clock: "
        "the per-query median is made of sub-millisecond queries and moves with the host's "
        "load more than the corner-to-corner figure; compare figures from one run only.",
        body=_astar, headline=_headline),
}
