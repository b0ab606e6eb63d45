"""The results page's section for `benchmarks/bench_faults.py`."""

from __future__ import annotations

from . import Json, Section
from ._markdown import dash, table, yes


def _faults(d: Json) -> list[str]:
    rows = [[f"`{r['spec']}`", r["expected"], r["observed"] or "-", dash(r["reaction_s"]),
             r["end_state"], yes(r["handled"])] for r in d["runs"]]
    return [f"{d['handled']} of {d['total']} faults handled ({d['arena']} arena, seed "
            f"{d['seed']}).", ""] + table(
        ["fault", "expected", "observed", "reaction [s]", "end state", "handled"], rows)


SECTIONS = {
    "faults": Section(
        "Faults flown into the contest mission",
        "Each fault kind injected once into the mission (`quadmission sim --fault`), its "
        "expected reaction looked up in the error policy, judged against what the mission "
        "and the FCU did.",
        body=_faults),
}
