"""The results page's section for `benchmarks/bench_aruco_table1.py`."""

from __future__ import annotations

from . import Json, Results, Row, Section
from ._markdown import pct, ratio, table


def _aruco_table1(d: Json) -> list[str]:
    lines = table(["marker", "distance", "lighting", "seed 003", "OpenCV defaults", "ours"],
                  [[f"{c['size_cm']} cm", f"{c['distance_cm']} cm", c["lighting"],
                    pct(c["seed_table1_rate"]), pct(c["baseline_rate"]), pct(c["ours_rate"])]
                   for c in d["cells"]])
    ms = d["detect_ms_per_frame"]
    return [*lines, f"{d['attempts_per_cell']} attempts per cell, {d['camera']}. Per frame, "
            f"ours costs {ratio(ms['ratio'])} the baseline's single `detectMarkers` "
            f"({ms['ours']:.0f} vs {ms['baseline']:.0f} ms on this host and load).", ""]


def _headline(r: Results) -> list[Row]:
    cells = r["aruco_table1"]["cells"]
    return [["ArUco, seed 003 Table 1 (8 cells): worst cell, ours / OpenCV defaults / seed",
             " / ".join(pct(min(c[key] for c in cells))
                        for key in ("ours_rate", "baseline_rate", "seed_table1_rate")),
             "seed 003 Table 1"]]


SECTIONS = {
    "aruco_table1": Section(
        "ArUco recognition: seed 003 Table 1 in the simulator",
        "Success rate per cell (the ID decoded and nothing else) for the seed's figures, "
        "OpenCV's default detector and our scanner, on the airframe's camera with the camera "
        "sensor model.",
        body=_aruco_table1, headline=_headline),
}
