"""Every fault kind flown once into the contest mission (default arena, seed 0), judged
by its expected reaction (issue 22's table, ``quadmission/evaluation/faults.py``).

A kind that acts in flight is injected 25 s in (3 s into the exploration); a kind whose
reaction comes at the end of a phase (a pad's marker gone, the robot absent, the
operator silent, the down camera dark) from the start (the operator once it has sent
START: silent from 0 s it never does, and the mission stays idle), and the run flies the
whole mission. A ridden-out kind that is a step (a jump, a robot across) is flown
``--ride-s`` past it (not to the end of the mission: 5 min of wall each), which is where
its trouble would show; one with a duration flies the whole mission, which it must let
complete (``Expectation.completes``).

Writes ``{"runs": [{"spec", "expected", "observed", "reaction_s", "end_state",
"handled", "result", "reason", "sim_s", "wall_s"}], "handled", "total"}`` to ``--out``
(default benchmarks/results/faults.json), after every run (a long run can be stopped).
``--only KIND`` flies the specs of those kinds and keeps the other runs already in
``--out`` (a re-flown spec replaces its run; the runs in the order of ``SPECS``).
"""

from __future__ import annotations

import json
import math
import tempfile
import time
from pathlib import Path

from _harness import bench_parser, progress, write_result

from quadmission.evaluation.faults import Handler, expectation
from quadmission.scenarios import ScenarioOptions
from quadmission.scenarios.mission.scenario import MISSION_LIMIT_S, fly_mission
from sim.fault_spec import parse_fault

AT_S = 25.0  # s: 3 s into the exploration of the default arena, seed 0
SPECS = (
    f"battery_low@{AT_S:g}", f"battery_critical@{AT_S:g}", f"vio_stop@{AT_S:g}:2",
    f"vio_stop@{AT_S:g}", f"link_lost@{AT_S:g}:3", f"operator_abort@{AT_S:g}",
    f"node_stop@{AT_S:g},name=flight_control", f"node_stop@{AT_S:g},name=mapping",
    f"node_stop@{AT_S:g},name=vio",
    f"wind_gust@{AT_S:g}:2,force=2", f"vio_jump@{AT_S:g},x=0.5,y=0.3",
    f"vio_delay@{AT_S:g}:5,delay_ms=200", f"latency_spike@{AT_S:g}:3,latency_ms=300",
    f"packet_burst@{AT_S:g}:3,loss=0.5", f"clock_jump@{AT_S:g},offset_ms=2000",
    f"light_drop@{AT_S:g}", f"depth_dark@{AT_S:g}:5", f"robot_across@{AT_S:g}",
    "operator_silent@10", "pad_occluded@0,pad=4", "camera_dark@60:60", "robot_absent@0",
)


def fly(spec: str, ride_s: float) -> dict[str, object]:
    fault = parse_fault(spec)
    expected = expectation(fault)
    # ridden out and over (a duration): the mission must complete, so it flies whole
    rides = expected.handler is Handler.NOBODY and not expected.completes
    limit = fault.at_s + ride_s if rides else MISSION_LIMIT_S
    with tempfile.TemporaryDirectory() as out:
        t0 = time.perf_counter()
        report = fly_mission(ScenarioOptions(out=Path(out), seed=0, faults=(fault,)),
                             limit_s=limit)
        wall = time.perf_counter() - t0
    (judged,) = report["faults"]
    return {**judged, "result": report["result"], "reason": report["reason"],
            "limit_s": limit, "sim_s": report["sim_time_s"], "wall_s": round(wall, 1)}


def _flies(run_spec: str, spec: str) -> bool:
    """A run's spec (written back in full, with what the app filled in: the target robot)
    is that of ``spec`` from SPECS: same kind, time, duration, and every key ``spec``
    gives."""
    run, want = parse_fault(run_spec), parse_fault(spec)
    given = [(k, v) for k, v in want.values if not math.isnan(v)]
    return ((run.kind, run.at_s, run.duration_s, run.texts) ==
            (want.kind, want.at_s, want.duration_s, want.texts)
            and all(run.value(k) == v for k, v in given))


def main(argv: list[str] | None = None) -> int:
    p = bench_parser(__doc__, "faults")
    p.add_argument("--ride-s", type=float, default=20.0,
                   help="s flown past a ridden-out fault's end (default 20)")
    p.add_argument("--only", action="append", default=[], metavar="KIND")
    args = p.parse_args(argv)
    specs = [s for s in SPECS if not args.only or s.split("@")[0] in args.only]
    kept: list[dict[str, object]] = []
    if args.only and args.out.exists():
        kept = json.loads(args.out.read_text())["runs"]
    flown: dict[str, dict[str, object]] = {}
    for spec in specs:
        run = fly(spec, args.ride_s)
        flown[spec] = run
        progress(f"{spec:42s} {run['observed']!s:48s} {run['end_state']!s:20s} "
                 f"handled={run['handled']} ({run['wall_s']} s)")
        runs = [flown.get(s) or next((r for r in kept if _flies(str(r["spec"]), s)), None)
                for s in SPECS]
        runs = [r for r in runs if r is not None]
        write_result(args.out, {
            "arena": "contest (default)", "seed": 0, "runs": runs,
            "handled": sum(bool(r["handled"]) for r in runs), "total": len(runs)}, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
