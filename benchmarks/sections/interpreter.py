"""The results page's section for `benchmarks/bench_interpreter.py`."""

from __future__ import annotations

from . import Json, Section
from ._markdown import ratio, span, table, yes


def _interpreter(d: Json) -> list[str]:
    b, c = d["baseline"], d["candidate"]
    lines = table(["interpreter", "best RTF", "RTF over the rounds"], [
        [f"`{b['executable']}` {b['version']} (shared libpython: {yes(b['libpython_shared'])})",
         d["rtf_baseline"], span([r["baseline"]["rtf"] for r in d["rounds"]])],
        [f"`{c['executable']}` {c['version']} (shared libpython: {yes(c['libpython_shared'])})",
         d["rtf_candidate"], span([r["candidate"]["rtf"] for r in d["rounds"]])],
    ])
    return [f"{d['scenario']}; {len(d['rounds'])} interleaved rounds.", "", *lines,
            f"Ratio of the best runs {ratio(d['ratio_best'])}, median of the rounds' own ratios "
            f"{ratio(d['ratio_median_of_rounds'])}, on CPU time {ratio(d['ratio_cpu_best'])}; "
            f"the same trajectory: {'yes' if d['same_trajectory'] else 'NO'}.", ""]


SECTIONS = {
    "interpreter": Section(
        "Interpreter: pyenv's CPython against Debian's",
        "The same square, bit for bit, on a pyenv build (shared libpython, no PGO) and on "
        "Debian's `/usr/bin/python3` (PGO + LTO, static), in interleaved rounds.",
        body=_interpreter),
}
