"""The results page's section for `benchmarks/bench_scanner_overhead.py`."""

from __future__ import annotations

from . import Json, Section
from ._markdown import ratio, table


def _scanner_overhead(d: Json) -> list[str]:
    lines = table(["figure", "value", "baseline", "ratio"], [
        ["scanner node per frame (convert, detect, measure, publish, deliver)",
         f"{d['node_ms']:.0f} ms", f"bare `detectMarkers` {d['bare_detect_ms']:.0f} ms",
         ratio(d["ratio_node_over_bare"])]])
    rows = []
    for lighting, s in d["stretch_pass"].items():
        new, old = s["windows_13_33"], s["windows_3_53"]
        rows.append([f"STRETCH pass, 3 adaptive windows vs 6, {lighting}",
                     f"{new['ms_per_frame']:.0f} ms, {new['markers']} markers",
                     f"{old['ms_per_frame']:.0f} ms, {old['markers']} markers",
                     ratio(new["ms_per_frame"] / old["ms_per_frame"])])
    lines = [*lines, *table(["figure", "ours", "6 windows", "ratio"], rows)]
    half = d.get("half_resolution")
    if half:
        rows = []
        for lighting in ("light", "dark"):
            h = half[lighting]
            diff = h["corner_diff_px"]
            rows.append([lighting, f"{h['frames']} ({h['frames_halved']} halved)",
                         f"{h['markers_halved']} (lost {h['lost_by_halving']}, "
                         f"gained {h['gained_by_halving']})", f"{h['markers_full']}",
                         f"{diff['p50']} / {diff['p95']} / {diff['max']} px",
                         f"{h['ms_per_frame']['halved']:.1f} ms",
                         f"{h['ms_per_frame']['full']:.1f} ms",
                         ratio(h["ratio_halved_over_full"])])
        seeds = half["arena_seeds"]
        floors = ", ".join(f"{k}: {v} px" for k, v in half["min_side_px"].items())
        lines += ["", f"Halved search against full resolution, the node's floor at each height "
                      f"({floors}), over the pads and robots of random arenas "
                      f"{seeds[0]}-{seeds[1]}:", "",
                  *table(["lighting", "frames", "markers halved", "markers full",
                          "corner difference p50 / p95 / max", "halved per frame",
                          "full per frame", "ratio"], rows)]
    return lines


SECTIONS = {
    "scanner_overhead": Section(
        "ArUco scanner node overhead",
        "What the node adds around detection, the cost of the STRETCH pass (run on every "
        "frame where the plain pass finds nothing) with 3 adaptive windows against 6, and "
        "the halved search against the full-resolution one on the same frames. Times move "
        "with the host's load; the ratios are measured in the same run.",
        body=_scanner_overhead),
}
