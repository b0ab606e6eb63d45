"""How late and how long a process's callbacks run, per node, on the host's clock.

A node process on the wall clock (:class:`~runtime.processes.executor.ClockedExecutor`
without ``use_sim_time``) keeps, for each node, three distributions in nanoseconds:

- ``take_delay``: a message's wait in DDS, from its reception (rmw's
  ``received_timestamp``) to the process taking it off the transport. A process busy in a
  long callback does not take what arrives meanwhile: this is where that shows.
- ``latency``: from when a callback was due to when it started: a timer's time; for a
  message or a request, its take; for a future's or a task's step, the host's time when
  it was made due. The callbacks before it in the same process are what makes it late.
- ``run``: how long the callback ran.

A message's whole wait is its take delay plus its latency. Each distribution is a
histogram on a log scale (:data:`BINS_PER_OCTAVE` bins a factor of 2, 9 % wide), with its
exact count and largest value, so a long flight costs a few hundred integers a node.

Set :data:`STATS_VARIABLE` to a folder and every node process on the wall clock writes
``<folder>/<process>.<pid>.json`` when it ends, on SIGINT or SIGTERM too (not when
killed; :meth:`CallbackStats.write`);
:func:`merge` reads a folder's files back, per node. ``benchmarks/bench_realtime.py``
uses it; nothing is kept otherwise.
"""

from __future__ import annotations

import json
import logging
import math
import os
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = ["BINS_PER_OCTAVE", "STATS_VARIABLE", "CallbackStats", "Histogram", "merge",
           "stats_folder"]

STATS_VARIABLE = "QUADMISSION_CALLBACK_STATS"
"""A folder: node processes on the wall clock write their callback statistics there."""

BINS_PER_OCTAVE = 8
_log = logging.getLogger(__name__)
KINDS = ("take_delay", "latency", "run")


def stats_folder() -> Path | None:
    """The folder :data:`STATS_VARIABLE` names, or None when it is unset or empty."""
    value = os.environ.get(STATS_VARIABLE, "").strip()
    return Path(value) if value else None


@dataclass
class Histogram:
    """Durations [ns] counted in log-spaced bins (bin ``b`` holds ``2**(b/8)`` up to
    ``2**((b+1)/8)`` ns; durations under 1 ns go to bin 0)."""

    bins: dict[int, int] = field(default_factory=dict)
    count: int = 0
    max_ns: int = 0

    def add(self, ns: int) -> None:
        b = int(math.log2(ns) * BINS_PER_OCTAVE) if ns > 1 else 0
        self.bins[b] = self.bins.get(b, 0) + 1
        self.count += 1
        if ns > self.max_ns:
            self.max_ns = ns

    def merge(self, other: Histogram) -> None:
        for b, n in other.bins.items():
            self.bins[b] = self.bins.get(b, 0) + n
        self.count += other.count
        self.max_ns = max(self.max_ns, other.max_ns)

    def quantile_ns(self, q: float) -> float:
        """The ``q`` quantile (0..1): the geometric middle of the bin it falls in, never
        above the largest value seen. NaN when empty."""
        if not 0.0 <= q <= 1.0:
            raise ValueError(f"quantile {q} is outside 0..1")
        if self.count == 0:
            return math.nan
        rank, seen = q * self.count, 0
        for b in sorted(self.bins):
            seen += self.bins[b]
            if seen >= rank and seen > 0:
                return min(2.0 ** ((b + 0.5) / BINS_PER_OCTAVE), float(self.max_ns))
        return float(self.max_ns)

    def summary_ms(self) -> dict[str, float | int | None]:
        """``{"n", "p50", "p99", "max"}``, in milliseconds (None when empty)."""
        def ms(ns: float) -> float | None:
            return None if math.isnan(ns) else round(ns / 1e6, 3)
        return {"n": self.count, "p50": ms(self.quantile_ns(0.5)),
                "p99": ms(self.quantile_ns(0.99)),
                "max": ms(float(self.max_ns)) if self.count else None}

    def to_json(self) -> dict[str, Any]:
        return {"bins": {str(b): n for b, n in sorted(self.bins.items())},
                "count": self.count, "max_ns": self.max_ns}

    @classmethod
    def from_json(cls, raw: dict[str, Any]) -> Histogram:
        return cls({int(b): int(n) for b, n in raw["bins"].items()}, int(raw["count"]),
                   int(raw["max_ns"]))


class CallbackStats:
    """Per node (its name): the three histograms of :data:`KINDS`."""

    def __init__(self) -> None:
        self.nodes: defaultdict[str, dict[str, Histogram]] = defaultdict(
            lambda: {kind: Histogram() for kind in KINDS})

    def callback(self, node: str, latency_ns: int, run_ns: int) -> None:
        h = self.nodes[node]
        h["latency"].add(latency_ns)
        h["run"].add(run_ns)

    def take(self, node: str, delay_ns: int) -> None:
        self.nodes[node]["take_delay"].add(delay_ns)

    def summary_ms(self) -> dict[str, dict[str, dict[str, float | int | None]]]:
        """Per node, per kind: n, p50, p99 and max [ms]."""
        return {node: {kind: h.summary_ms() for kind, h in kinds.items()}
                for node, kinds in sorted(self.nodes.items()) if node}

    def write(self, folder: Path, process: str) -> Path:
        """``folder/<process>.<pid>.json`` (a respawned process writes a file of its own)."""
        folder.mkdir(parents=True, exist_ok=True)
        path = folder / f"{process}.{os.getpid()}.json"
        partial = path.with_suffix(".part")  # renamed whole: a process killed while it
        partial.write_text(json.dumps({  # writes leaves no half file to merge
            "process": process,
            "nodes": {node: {kind: h.to_json() for kind, h in kinds.items()}
                      for node, kinds in sorted(self.nodes.items())}}), encoding="utf-8")
        partial.replace(path)
        return path


def merge(folder: Path) -> dict[str, dict[str, Any]]:
    """Every file a run's processes wrote in ``folder``, per node: its process and the
    summaries of :meth:`CallbackStats.summary_ms` (a node of a respawned process, over its
    lives)."""
    stats = CallbackStats()
    process: dict[str, str] = {}
    for path in sorted(folder.glob("*.json")):
        try:
            raw = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:  # one bad file does not lose the others
            _log.warning("callback statistics %s left out: %s", path, exc)
            continue
        for node, kinds in raw["nodes"].items():
            process[node] = raw["process"]
            for kind, h in kinds.items():
                stats.nodes[node][kind].merge(Histogram.from_json(h))
    return {node: {"process": process[node], **kinds}
            for node, kinds in stats.summary_ms().items()}
