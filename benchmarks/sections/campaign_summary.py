"""The results page's sections for campaigns' `summary.json` (`quadmission campaign`)."""

from __future__ import annotations

from . import Json, Results, Row, Section
from ._markdown import cm, dash, pct, table

#: issue 22: arena campaign runs that must complete with every landing inside
ARENAS_TARGET = "74 of 75"
#: issue 39: transient campaign runs that must complete with every landing inside
TRANSIENT_TARGET = "95 %"


def _campaign_run(d: Json) -> list[str]:
    """A campaign's ``summary.json`` (``quadmission campaign``, copied here)."""
    session, s = d["session"], d["summary"]
    rate = s["rate"]
    versions = ", ".join(f"`{v}` ({n})" for v, n in s["code_versions"])
    lines = [f"**{rate['passed']} of {rate['runs']} runs passed ({pct(rate['rate'])}).** "
             f"`{session['source']}`, {session['cells']} runs; code {versions}.", ""]
    if len(s["by_kind"]) > 1 or s["by_kind"][0]["rate"]["group"] != "clean":
        lines += table(["fault kind", "passed", "expected", "observed (runs)",
                        "reaction p50 / max [s]"], [
            [k["rate"]["group"], f"{k['rate']['passed']}/{k['rate']['runs']}", k["expected"],
             ", ".join(f"{o} ({n})" for o, n in k["observed"]) or "-",
             f"{dash(k['reaction_s']['p50'] and round(k['reaction_s']['p50'], 2))} / "
             f"{dash(k['reaction_s']['max'] and round(k['reaction_s']['max'], 2))}"]
            for k in s["by_kind"]])
    t, w = s["touchdown_m"], s["wall_s"]
    rows = [[f"passed, {r['group']}", f"{r['passed']}/{r['runs']} ({pct(r['rate'])})"]
            for r in s["by_lighting"]]
    if t["n"]:
        rows.append(["landings inside their pad; touchdown error p50 / p90 / max",
                     f"{s['landings_inside']} of {s['landings']}; {cm(t['p50'])} / "
                     f"{cm(t['p90'])} / {cm(t['max'])}"])
    rows.append(["wall time per run, p50 / max; runs per CPU-hour",
                 f"{w['p50']:.0f} / {w['max']:.0f} s; {s['runs_per_cpu_hour']:.0f}"])
    lines += table(["figure", "value"], rows)
    lines += [f"- `{f['cell']}` (code `{f['code_version']}`): {f['result']}: {f['why']}"
              for f in s["failed"]]
    return lines + ([""] if s["failed"] else [])


def _passed(d: Json) -> str:
    """Runs passed of runs flown, and of the campaign's runs when it was stopped short."""
    rate, cells = d["summary"]["rate"], d["session"]["cells"]
    return f"{rate['passed']} of {rate['runs']}" + (
        f" flown ({cells} planned)" if rate["runs"] < cells else "")


def _faults_headline(r: Results) -> list[Row]:
    d = r["campaign_faults"]
    kinds = len(d["summary"]["by_kind"])
    return [[f"fault campaign ({kinds} kinds x {d['session']['cells'] // kinds} seeds): runs "
             "handled", _passed(d), "target: all"]]


def _arenas_headline(r: Results) -> list[Row]:
    d = r["campaign_arenas"]
    s = d["summary"]
    lighting = ", ".join(f"{g['runs']} {g['group']}" for g in sorted(
        s["by_lighting"], key=lambda g: g["group"] != "light"))
    return [[f"contest mission, {d['session']['cells']} random arenas ({lighting}; the arena "
             "campaign): completed, every landing inside",
             f"{_passed(d)}; landings inside: {s['landings_inside']} of {s['landings']}",
             f"target {ARENAS_TARGET}"]]


def _transient_headline(r: Results) -> list[Row]:
    d = r["campaign_transient"]
    s = d["summary"]
    return [[f"contest mission with 1-2 transient faults drawn from the seed, "
             f"{d['session']['cells']} random arenas (the transient campaign): completed, "
             "every landing inside",
             f"{_passed(d)}; landings inside: {s['landings_inside']} of {s['landings']}",
             f"target {TRANSIENT_TARGET}"]]


SECTIONS = {
    "campaign_faults": Section(
        "Fault campaign (`config/campaigns/faults.yaml`)",
        "Every fault kind x 3 seeds in the contest arena, each at a time that hits the phase "
        "it matters in, judged by its expected reaction (issue 22): a run passes when every "
        "fault's observed reaction is the expected one, nothing is hit and no node raises. "
        "The campaign's `summary.json`, copied here.",
        body=_campaign_run, source="quadmission campaign", headline=_faults_headline),
    "campaign_arenas": Section(
        "Arena campaign (`config/campaigns/arenas.yaml`)",
        "Clean contest missions on random arenas 100-149 in the light and 100-124 in the "
        f"dark (issue 22's target: {ARENAS_TARGET} complete with every landing inside). The "
        "campaign's `summary.json`, copied here.",
        body=_campaign_run, source="quadmission campaign", headline=_arenas_headline),
    "campaign_transient": Section(
        "Transient campaign (`config/campaigns/transient.yaml`)",
        "Contest missions on random arenas 200-229, light and dark, each with one or two "
        "transient faults drawn from its seed (VIO and FCU-link drops, packet bursts, camera "
        "blinks, a node killed and restarted; issue 39's target: "
        f"{TRANSIENT_TARGET} complete with every landing inside). The campaign's "
        "`summary.json`, copied here.",
        body=_campaign_run, source="quadmission campaign", headline=_transient_headline),
}
