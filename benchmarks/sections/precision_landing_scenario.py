"""The results page's sections for `quadmission sim --scenario precision-landing`."""

from __future__ import annotations

from . import Json, Results, Row, Section
from ._markdown import cm, num, table

#: seed 003 Table 3: touchdown RMSE of its precision landings on pads 3, 5 and 7 (m).
SEED003_LANDING_RMSE_M = 0.068


def _landing_scenario(d: Json) -> list[str]:
    inside = sum(landing["inside_pad"] for landing in d["landings"])
    lines = table(["figure", "value", "baseline"], [
        ["pads landed / inside the pad", f"{d['landed']} / {inside} of {len(d['landings'])}",
         "all inside"],
        ["touchdown RMSE / max error", f"{cm(d['rmse_m'])} / {cm(d['max_error_m'])}",
         f"seed 003 Table 3: {cm(SEED003_LANDING_RMSE_M)} RMSE over 3 pads "
         f"(ratio {num(d['rmse_m'] / SEED003_LANDING_RMSE_M)})"],
        ["crashed", "yes" if d["crashed"] else "no", "-"],
    ])
    lines += table(["pad", "start xy (m)", "touchdown error", "inside", "duration"],
                   [[x["pad"], ", ".join(f"{v:.2f}" for v in x["start_xy_m"]),
                     cm(x["touchdown_error_m"]), "yes" if x["inside_pad"] else "no",
                     f"{x['duration_s']:.1f} s"] for x in d["landings"]])
    return lines


def _headline(r: Results) -> list[Row]:
    light, dark = r["precision_landing_scenario_light"], r["precision_landing_scenario_dark"]

    def landed(d: Json) -> str:
        inside = sum(x["inside_pad"] for x in d["landings"])
        return f"{inside}/{len(d['landings'])} inside, {cm(d['rmse_m'])} / {cm(d['max_error_m'])}"

    return [["precision landing, default arena, light / dark: inside, touchdown RMSE / max",
             f"{landed(light)}; {landed(dark)}",
             f"seed 003: {cm(SEED003_LANDING_RMSE_M)} RMSE"]]


SECTIONS = {
    "precision_landing_scenario_light": Section(
        "Precision landing, default arena, light",
        "One precision landing per pad, each from the floor 0.3-1.0 m beside it; the run is "
        "the same on any host (`report.json` of the scenario).",
        body=_landing_scenario, headline=_headline,
        source="`quadmission sim --scenario precision-landing --lighting light`"),
    "precision_landing_scenario_dark": Section(
        "Precision landing, default arena, dark",
        "As above, in the dark preset (long exposure, high gain, noisy frames).",
        body=_landing_scenario,
        source="`quadmission sim --scenario precision-landing --lighting dark`"),
}
