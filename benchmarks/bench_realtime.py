"""The companion in real time: companion.yaml against `quadmission vehicle` on the wall clock.

Each way flies the contest mission (default arena, seed 0; ``--until-state`` for a
shorter check) through ``quadmission fly-realtime``'s parts
(:func:`quadmission.scenarios.mission.realtime.fly_realtime`):

- ``both_cores``: as it starts, every process on either core;
- ``one_core``: the companion's and the operator's processes pinned to CPU 0 (as
  ``taskset -c 0``), the vehicle to CPU 1 (it stands for hardware with CPUs of its own);
- ``busy``: a process spinning on a core beside them, for the whole flight.

Recorded for each way: each process's CPU (CPU-s per second of its life, sampled from
``/proc`` every 0.5 s) and largest resident memory; the companion's total against the one
core the budget allows; the offboard setpoint stream as the FCU took it (heartbeats, the
largest gap, gaps over 0.5 s: PX4 needs 2 Hz and drops offboard after ``COM_OF_LOSS_T``);
how far the vehicle fell behind real time; the age of the vision data the FCU fuses (its
time at the fusion less the sample's stamp: p50, p99, largest); each companion node's
callbacks (:mod:`runtime.processes.callback_stats`: a message's wait in DDS before its
process took it, how late a callback started after it was due, how long it ran: p50, p99,
largest); the mission's result (completed, landings inside, touchdown RMSE).

Writes ``{"ways": {name: {...}}, "until_state", "host"}`` to ``--out`` (default
benchmarks/results/realtime.json) after each way. Needs the host to itself.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from _harness import (
    bench_parser,
    children,
    cpu_seconds,
    process_name,
    progress,
    rss_mb,
    write_result,
)

from quadmission.scenarios.mission.realtime import RealtimeOptions, fly_realtime
from quadmission.vehicle.run import VehicleOptions

WAYS = ("both_cores", "one_core", "busy")
BUDGET_CPU_S_PER_S = 1.0  # issue 38: the companion uses at most one core on average


class Sampler(threading.Thread):
    """CPU seconds and memory of every process below this one, every ``period_s``."""

    def __init__(self, period_s: float = 0.5) -> None:
        super().__init__(daemon=True)
        self.period_s = period_s
        self.seen: dict[int, dict[str, Any]] = {}
        self._done = threading.Event()

    def _walk(self, pid: int) -> list[int]:
        found = children(pid)
        return found + [p for child in found for p in self._walk(child)]

    def run(self) -> None:
        while not self._done.wait(self.period_s):
            now = time.monotonic()
            for pid in self._walk(os.getpid()):
                cpu, rss = cpu_seconds(pid), rss_mb(pid)
                if cpu is None or rss is None:
                    continue
                s = self.seen.setdefault(pid, {"name": process_name(pid), "first": now,
                                               "rss_mb": 0.0, "argv0": _argv(pid)})
                s.update(cpu_s=cpu, last=now, rss_mb=max(s["rss_mb"], rss))

    def stop(self) -> dict[str, dict[str, float]]:
        """Per process of a launch (by its name) or the vehicle: CPU-s per s, MiB."""
        self._done.set()
        self.join()
        out: dict[str, dict[str, float]] = {}
        for s in self.seen.values():
            name = s["name"] or ("vehicle" if "vehicle" in s["argv0"] else None)
            life = s["last"] - s["first"]
            if name is None or life < 5.0:
                continue
            out[name] = {"cpu_s_per_s": round(s["cpu_s"] / life, 3),
                         "cpu_s": round(s["cpu_s"], 1), "rss_mb": round(s["rss_mb"], 1)}
        return out


def _argv(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()[:300]
    except OSError:
        return ""


def fly(way: str, until_state: str | None, domain_id: int) -> dict[str, Any]:
    busy = subprocess.Popen([sys.executable, "-c", "while True: pass"]) if way == "busy" \
        else None
    sampler = Sampler()
    sampler.start()
    t0 = time.perf_counter()
    try:
        with tempfile.TemporaryDirectory() as out:
            vehicle = VehicleOptions(out=Path(out) / "vehicle", domain_id=domain_id)
            report = fly_realtime(RealtimeOptions(
                out=Path(out), vehicle=vehicle, until_state=until_state,
                companion_cpus=(0,) if way == "one_core" else None,
                vehicle_cpus=(1,) if way == "one_core" else None))
    finally:
        if busy is not None:
            busy.kill()
            busy.wait()
    processes = sampler.stop()
    companion = {n: p for n, p in processes.items() if n not in ("vehicle", "operator")}
    total = round(sum(p["cpu_s_per_s"] for p in companion.values()), 3)
    vehicle_figures = report.get("vehicle", {})
    return {
        "result": report["result"], "verdict": report["verdict"],
        "all_inside": report["all_inside"], "touchdown_rmse_m": report["touchdown_rmse_m"],
        "companion_cpu_s_per_s": total, "within_budget": total <= BUDGET_CPU_S_PER_S,
        "processes": processes, "setpoints": vehicle_figures.get("setpoints"),
        "vehicle_behind": vehicle_figures.get("behind"),
        "fcu_failsafes": report.get("fcu_failsafes"), "wall_s": round(time.perf_counter() - t0),
        "vision": vehicle_figures.get("vision"), "callbacks": report.get("callbacks"),
    }


def main(argv: list[str] | None = None) -> int:
    p = bench_parser(__doc__, "realtime")
    p.add_argument("--ways", nargs="+", choices=WAYS, default=list(WAYS))
    p.add_argument("--until-state", default=None,
                   help="end each flight once the mission enters this state (a short check)")
    p.add_argument("--domain-id", type=int, default=39, help="ROS_DOMAIN_ID of the flights")
    args = p.parse_args(argv)
    result: dict[str, Any] = {"arena": "contest (default)", "seed": 0,
                              "until_state": args.until_state,
                              "budget_cpu_s_per_s": BUDGET_CPU_S_PER_S, "ways": {}}
    for way in args.ways:
        run = result["ways"][way] = fly(way, args.until_state, args.domain_id)
        progress(f"{way}: {run['verdict']}; companion {run['companion_cpu_s_per_s']} CPU-s/s, "
                 f"largest setpoint gap {(run['setpoints'] or {}).get('max_gap_s')} s")
        write_result(args.out, result, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
