"""The results page's section for `benchmarks/bench_realtime.py`."""

from __future__ import annotations

from . import Json, Results, Row, Section
from ._markdown import cm, dash, table, yes


def _ms(figures: Json | None, *keys: str) -> str:
    """``p50 / p99`` [ms] from a summary's keys, or a dash."""
    if not figures or figures.get(keys[0]) is None:
        return "-"
    return " / ".join(f"{figures[k]:.2f}" for k in keys)


def _outcomes(d: Json) -> list[str]:
    rows = []
    for way, w in d["ways"].items():
        setpoints = w["setpoints"] or {}
        behind = w["vehicle_behind"] or {}
        rows.append([way, w["result"], yes(w["all_inside"]),
                     dash(w["touchdown_rmse_m"] and cm(w["touchdown_rmse_m"])),
                     f"{w['companion_cpu_s_per_s']:.3f}", dash(setpoints.get("max_gap_s")),
                     _ms(w.get("vision"), "age_p50_ms", "age_p99_ms"),
                     dash(behind.get("max_lag_s"))])
    return table(["way", "result", "every landing inside", "touchdown RMSE",
                  "companion CPU-s per s", "largest setpoint gap [s]",
                  "vision age p50 / p99 [ms]", "vehicle's largest lag [s]"], rows)


def _processes(d: Json) -> list[str]:
    ways = list(d["ways"])
    names = sorted({n for w in d["ways"].values() for n in w["processes"]})
    rows = []
    for name in names:
        cells = []
        for way in ways:
            p = d["ways"][way]["processes"].get(name)
            cells.append("-" if p is None else f"{p['cpu_s_per_s']:.3f} / {p['rss_mb']:.0f}")
        rows.append([name, *cells])
    return table(["process", *(f"{way}: CPU-s per s / MiB" for way in ways)], rows)


def _callbacks(d: Json) -> list[str]:
    ways = [w for w, r in d["ways"].items() if r.get("callbacks")]
    if not ways:
        return []
    nodes = sorted({n for w in ways for n in d["ways"][w]["callbacks"]})
    rows = []
    for node in nodes:
        cells = []
        for way in ways:
            c = d["ways"][way]["callbacks"].get(node)
            cells += ["-", "-"] if c is None else [
                _ms(c["latency"], "p50", "p99"), _ms(c["take_delay"], "p50", "p99")]
        first = next(d["ways"][w]["callbacks"][node] for w in ways
                     if node in d["ways"][w]["callbacks"])
        rows.append([node, first["process"], *cells])
    header = ["node", "process"]
    for way in ways:
        header += [f"{way}: latency p50 / p99 [ms]", f"{way}: take delay p50 / p99 [ms]"]
    return ["Per node: a callback's latency runs from when it was due (a timer's time, a "
            "message's take) to its start; a message's take delay from its reception in DDS "
            "to its process taking it.", ""] + table(header, rows)


def _realtime(d: Json) -> list[str]:
    return ([f"Budget: the companion at most {d['budget_cpu_s_per_s']:g} CPU-s per second; "
             "the largest setpoint gap under 0.5 s.", ""] + _outcomes(d) + _processes(d)
            + _callbacks(d))


def _headline(r: Results) -> list[Row]:
    d = r.get("realtime")
    if not d or "both_cores" not in d["ways"]:
        return []
    w = d["ways"]["both_cores"]
    worst_gap = max((x["setpoints"] or {}).get("max_gap_s") or 0.0 for x in d["ways"].values())
    done = sum(x["result"] == "completed" and bool(x["all_inside"]) for x in d["ways"].values())
    return [["the mission in real time, companion.yaml against `quadmission vehicle`: "
             "completed with every landing inside; the companion's CPU; the largest "
             "setpoint gap",
             f"{done} of {len(d['ways'])} ways; {w['companion_cpu_s_per_s']:.2f} CPU-s per s "
             f"on both cores; {worst_gap:.2f} s",
             f"budget {d['budget_cpu_s_per_s']:g} CPU-s per s, gap under 0.5 s"]]


SECTIONS = {
    "realtime": Section(
        "The companion in real time",
        "companion.yaml against `quadmission vehicle` on the wall clock (no lockstep, no "
        "/clock), the whole mission, three ways: both cores, the companion pinned to one "
        "core, a busy process beside it.",
        body=_realtime, headline=_headline),
}
