"""The results page's section for `benchmarks/bench_bag_kill.py`."""

from __future__ import annotations

from . import Json, Section
from ._markdown import host_line, table, yes


def _bag_kill(d: Json) -> list[str]:
    return table(["figure", "value", "baseline"], [
        ["killed (SIGKILL) after", f"{d['killed_after_s']} s", "-"],
        ["indexed before / after repair",
         f"{yes(d['indexed_before_repair'])} / {yes(d['indexed_after_repair'])}", "-"],
        ["messages kept / read back by `AnyReader`",
         f"{d['messages_kept']} / {d['messages_read_by_anyreader']} of "
         f"{d['messages_before_repair']}", "all"],
        ["span read back", f"{d['span_read_s']} s", f"target {d['target_span_s']} s"],
        ["topics", d["topics"], "-"],
    ]) + host_line(None, d.get("load_average_1min"))


SECTIONS = {
    "bag_kill": Section(
        "Crash-safe recording",
        "`quadmission sim --scenario square --rtf 1 --record` killed with SIGKILL, the bag "
        "repaired with `quadmission bag repair` and read back with rosbags' `AnyReader`.",
        body=_bag_kill),
}
