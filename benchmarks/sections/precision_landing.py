"""The results page's section for `benchmarks/bench_precision_landing.py`."""

from __future__ import annotations

from . import Json, Results, Row, Section
from ._markdown import cm, num, table


def _precision_landing(d: Json) -> list[str]:
    rows = []
    for name, key in (("seed 003 (latest pose, no phases)", "seed_algorithm"),
                      ("ours (pose and attitude at capture time, phases, outlier rejection)",
                       "ours")):
        r = d[key]
        rows.append([name, f"{r['landed']} / {'all' if r['all_inside'] else 'not all'} inside",
                     cm(r["rmse_m"], 2), cm(r["max_error_m"], 1)])
    lines = table(["strategy", "landed / inside", "touchdown RMSE", "max"], rows)
    worst = d.get("max_ratio_ours_over_seed")
    latency = d.get("camera_latency_s")
    return [*lines, f"Ratio ours / seed: RMSE {num(d['rmse_ratio_ours_over_seed'])}"
                    + ("" if worst is None else f", worst case {num(worst)}")
                    + f", over {d['flown']} of {d['landings']} landings flown, "
                    f"{d['lighting']} preset"
                    + ("" if latency is None else
                       f", down camera latency {1000 * latency:.0f} ms") + ".", ""]


def _headline(r: Results) -> list[Row]:
    landing = r["precision_landing"]
    return [[f"precision landing, {landing['flown']} landings: touchdown RMSE, ours vs the "
             "seed's algorithm", f"{cm(landing['ours']['rmse_m'], 2)} vs "
             f"{cm(landing['seed_algorithm']['rmse_m'], 2)}",
             f"ratio {num(landing['rmse_ratio_ours_over_seed'])}"]]


SECTIONS = {
    "precision_landing": Section(
        "Precision landing: ours against the seed's algorithm",
        "The same seeded landings on random arenas flown by both strategies: the seed's (the "
        "marker error added to the latest pose, no phases) and ours (the pose and attitude at "
        "the frame's capture time, phases, outlier rejection).",
        body=_precision_landing, headline=_headline),
}
