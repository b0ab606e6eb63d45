"""What every benchmark script shares: its command line's ``--out``, the JSON it writes, the
host it ran on, and its progress lines.

A script runs as ``python benchmarks/bench_<name>.py --out benchmarks/results/<name>.json``
(``make bench``), so this folder is first on ``sys.path`` and the script imports
``_harness`` by name::

    parser = bench_parser(__doc__, "fcu")         # --out, default benchmarks/results/fcu.json
    parser.add_argument("--seconds", type=float, default=20.0)
    args = parser.parse_args(argv)
    ...
    write_result(args.out, result)

Standard library only: a script that only says ``--help`` imports nothing heavy through it.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

#: where ``make bench`` writes each benchmark's ``<name>.json``
RESULTS_DIR = Path(__file__).resolve().parent / "results"

#: ``bench_parser(..., out=REQUIRED)``: the script writes nowhere unless told
REQUIRED = "required"
#: ``bench_parser(..., out=OPTIONAL)``: without ``--out`` the script only prints its result
OPTIONAL = "optional"


def bench_parser(doc: str | None, out: str) -> argparse.ArgumentParser:
    """The script's parser: its docstring's first line as description, and ``--out``.

    ``out`` is the result's name (``--out`` defaults to ``benchmarks/results/<out>.json``),
    or :data:`REQUIRED` or :data:`OPTIONAL` (no default: ``args.out`` is None).
    """
    parser = argparse.ArgumentParser(description=(doc or "").strip().splitlines()[0])
    if out == REQUIRED:
        parser.add_argument("--out", type=Path, required=True, help="JSON file to write")
    elif out == OPTIONAL:
        parser.add_argument("--out", type=Path, default=None,
                            help="JSON file to write (default: only print the result)")
    else:
        default = RESULTS_DIR / f"{out}.json"
        parser.add_argument("--out", type=Path, default=default,
                            help=f"JSON file to write (default: benchmarks/results/{out}.json)")
    return parser


def result_json(result: Mapping[str, Any], indent: int = 2, *, allow_nan: bool = True) -> str:
    """The result as the JSON file holds it: ``indent`` spaces, a final newline.

    A NaN or an infinity is not JSON. With ``allow_nan`` it is written as Python's json
    module writes it (so a long run's figures are not lost) and named in a warning on
    stderr; without, :class:`ValueError` names where it is and nothing is written (a script
    whose results must be strict JSON, read by other tools, sets it False).
    """
    try:
        return json.dumps(result, indent=indent, allow_nan=False) + "\n"
    except ValueError:
        where = ", ".join(_not_json(result, "result")) or "the result"
        if not allow_nan:
            raise ValueError(f"{where}: NaN or infinity, not JSON; not written") from None
        progress(f"warning: {where}: NaN or infinity (not valid JSON); written as is")
        return json.dumps(result, indent=indent) + "\n"


def _not_json(value: Any, where: str) -> list[str]:
    """Where in ``value`` a float is NaN or infinite (``result["runs"][3]["rtf"]``)."""
    if isinstance(value, float):
        return [] if math.isfinite(value) else [where]
    if isinstance(value, Mapping):
        return [w for k, v in value.items() for w in _not_json(v, f"{where}[{k!r}]")]
    if isinstance(value, (list, tuple)):
        return [w for i, v in enumerate(value) for w in _not_json(v, f"{where}[{i}]")]
    return []


def write_result(out: Path | None, result: Mapping[str, Any], indent: int = 2, *,
                 allow_nan: bool = True) -> str:
    """Write ``result`` to ``out`` (its folder made when missing); nothing when ``out`` is
    None. Returns the JSON text, for a script that also prints it. ``allow_nan``: as
    :func:`result_json` (False: a NaN leaves ``out`` as it was)."""
    text = result_json(result, indent, allow_nan=allow_nan)
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(text, encoding="utf-8")
    return text


def progress(message: str) -> None:
    """A progress line on stderr, at once (stdout carries the result)."""
    print(message, file=sys.stderr, flush=True)


def load_1min(digits: int = 2) -> float:
    """The host's 1-minute load average now: other work on the host skews wall times."""
    return round(os.getloadavg()[0], digits)


def host(**load: Any) -> dict[str, Any]:
    """The host a result was measured on: Python version, machine, CPUs, and the loads the
    script took (its own keys, e.g. ``load_1min=load_1min()``)."""
    return {"python": platform.python_version(), "machine": platform.machine(),
            "cpus": os.cpu_count(), **load}


def seed_list(text: str) -> list[int]:
    """Seeds from "1-20", "3,7" or "2-4,6-20"."""
    seeds: list[int] = []
    for item in text.split(","):
        first, _, last = item.partition("-")
        seeds += list(range(int(first), int(last or first) + 1))
    return seeds


#: a fixed pure-Python workload: dict and list operations on small ints and tuples, the kind
#: networkx spends its time on (``reference_loop_s``)
REFERENCE_LOOP_ITEMS = 200_000


def reference_loop_s(repeats: int = 5) -> float:
    """Seconds this host takes for a fixed pure-Python loop (the best of ``repeats``).

    The same loop on every run and every host: a benchmark records it beside a ratio that
    moves with the host's speed (a pure-Python baseline slows more than numpy or C code on a
    busy host), so two runs' ratios can be read together with how fast the host was.
    """
    best = math.inf
    for _ in range(repeats):
        start = time.perf_counter()
        seen: dict[tuple[int, int], int] = {}
        frontier: list[tuple[int, int]] = []
        for i in range(REFERENCE_LOOP_ITEMS):
            key = (i % 997, i % 1009)
            seen[key] = seen.get(key, 0) + 1
            frontier.append(key)
            if len(frontier) > 64:
                frontier.pop(0)
        best = min(best, time.perf_counter() - start)
    return best


# -- processes, from /proc (Linux) ---------------------------------------------------------
_TICKS = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100


def cpu_seconds(pid: int) -> float | None:
    """User + system CPU seconds of ``pid`` (its threads included), or None once it is gone."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()
    except OSError:
        return None
    return (int(fields[11]) + int(fields[12])) / _TICKS  # utime, stime


def rss_mb(pid: int) -> float | None:
    """Resident memory of ``pid`` [MiB], or None once it is gone."""
    try:
        pages = int(Path(f"/proc/{pid}/statm").read_text().split()[1])
    except OSError:
        return None
    return pages * os.sysconf("SC_PAGE_SIZE") / 2**20


def process_name(pid: int) -> str | None:
    """The launch's name of a child process (its ProcessSpec's), from its command line."""
    try:
        argv = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
    except OSError:
        return None
    spec = next((a for a in argv if a.startswith(b'{"name"')), None)
    return None if spec is None else str(json.loads(spec)["name"])


def children(pid: int) -> list[int]:
    """The processes whose parent is ``pid``."""
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            if int(stat.rpartition(")")[2].split()[1]) == pid:
                found.append(int(entry.name))
    return found
