"""The results page's section for `benchmarks/bench_square_seeds.py`."""

from __future__ import annotations

from . import Json, Results, Row, Section
from ._markdown import num, span, table


def _square_seeds(d: Json) -> list[str]:
    runs = d["runs"]
    lines = table(["figure", "value", "baseline"], [
        ["landed / refused / crashed or failed",
         f"{d['landed']} / {d['refused']} / {d['crashed_or_failed']} of {len(runs)}",
         "land or refuse"],
        ["xy tracking RMSE, against " + " / ".join(sorted(
            {r.get("rmse_reference", "the setpoints").split(":")[0] for r in runs})),
         span([r["xy_rmse_m"] for r in runs], 3, "m"),
         f"target {d['target_xy_rmse_m']} m (worst/target "
         f"{num(d['worst_xy_rmse_m'] / d['target_xy_rmse_m'])})"],
        ["square side", span([r["side_m"] for r in runs], 2, "m"), "4 m at most"],
    ])
    lines += table(["seed", "arena", "verdict", "side"],
                   [[r["seed"], r["arena"], r["verdict"], f"{r['side_m']} m"] for r in runs])
    return lines


def _headline(r: Results) -> list[Row]:
    square = r["square_seeds"]
    return [["square on 21 arenas: landed, worst xy tracking RMSE",
             f"{square['landed']} of {len(square['runs'])}, {square['worst_xy_rmse_m']:.3f} m",
             f"target {square['target_xy_rmse_m']} m"]]


SECTIONS = {
    "square_seeds": Section(
        "Square flight on 21 arenas",
        "The companion stack's square (`quadmission sim --scenario square`) on the default "
        "arena and random arenas: land, or refuse with the reason when no square fits.",
        body=_square_seeds, headline=_headline),
}
