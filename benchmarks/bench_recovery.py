"""What a glitch that clears costs: issue 39's three flights, each beside the clean mission.

The default arena, seed 0, the whole contest mission each time:

- in process, the clean mission (the baseline), a 2 s FCU link loss during the take-off
  (``link_lost@10:2``) and a 3 s VIO loss while exploring (``vio_stop@30:3``); each
  faulted run is judged against the same seed's clean run: completed, every landing
  inside, and the seconds the mission took longer (``lost_s``, its ratio ``slowdown``);
- under ``--transport ros2`` (``config/launch/mission.yaml``, the lockstep with the
  simulator), the navigation process killed ``--kill-at`` wall seconds in (SIGKILL) and
  respawned by the launcher: the launch's exit code (0: the mission completed) and its
  HOLD and RESUME, read from the mission's log lines. A ros2 launch does not score
  ground truth; its mission time is set beside the in-process clean one.

Writes ``{"arena", "seed", "clean", "runs": [{"name", "transport", "spec", "result",
"held_s", "resumed_s", "sim_s", "lost_s", "slowdown", "landings", "inside", "rmse_m",
"replay", ...}]}`` to ``--out`` (default benchmarks/results/recovery.json) after every
run. ``--skip-ros2`` flies only the in-process ones, ``--ros2-only`` only the ros2 one
(keeping the in-process runs already in ``--out``).
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from _harness import bench_parser, progress, write_result

from quadmission.scenarios import ScenarioOptions
from quadmission.scenarios.mission.scenario import fly_mission
from sim.fault_spec import parse_faults

ROOT = Path(__file__).resolve().parents[1]
IN_PROCESS = (("fcu_link_lost_in_takeoff", "link_lost@10:2"),
              ("vio_lost_while_exploring", "vio_stop@30:3"))
#: ``[mission] INFO [t] [mission] mission: <state>`` in a ros2 launch's output
STATE_LINE = re.compile(r"\[mission\] INFO \[([0-9.]+)\] \[mission\] mission: (\S+)")


def _held(states: list[tuple[float, str]]) -> tuple[float | None, float | None]:
    """(when the mission first held, when it left ``held``) in simulated s, or None."""
    for i, (t, state) in enumerate(states):
        if state == "held":
            return t, states[i + 1][0] if i + 1 < len(states) else None
    return None, None


def fly_in_process(spec: str | None) -> dict[str, Any]:
    with tempfile.TemporaryDirectory() as out:
        t0 = time.perf_counter()
        report = fly_mission(ScenarioOptions(out=Path(out), seed=0,
                                             faults=parse_faults([spec] if spec else [])))
        wall = time.perf_counter() - t0
    states = [(float(s["t_s"]), str(s["state"])) for s in report["states"]]
    held_s, resumed_s = _held(states)
    landings = report["landings"]
    return {"transport": "inproc", "spec": spec, "result": report["result"],
            "reason": report["reason"], "held_s": held_s, "resumed_s": resumed_s,
            "sim_s": report["sim_time_s"], "score": report["score"],
            "landings": len(landings), "inside": sum(bool(x["inside_pad"]) for x in landings),
            "rmse_m": report["touchdown_rmse_m"], "crashed": report["crashed"],
            "observed": [f["observed"] for f in report.get("faults", [])],
            "wall_s": round(wall, 1),
            "replay": "quadmission sim --scenario mission --seed 0"
                      + (f" --fault {spec}" if spec else "")}


def fly_ros2(kill_at_s: float, domain_id: int, timeout_s: float) -> dict[str, Any]:
    spec = f"node_stop@{kill_at_s:g},name=navigation"
    command = [str(Path(sys.executable).with_name("quadmission")), "launch",
               "config/launch/mission.yaml",
               "--transport", "ros2", "--domain-id", str(domain_id), "--rtf", "1",
               "--fault", spec]
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as home:
        env = {**os.environ, "ROS_HOME": home, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
        done = subprocess.run(command, cwd=ROOT, env=env, capture_output=True, text=True,
                              timeout=timeout_s, check=False)
    wall = time.perf_counter() - t0
    lines = done.stdout.splitlines() + done.stderr.splitlines()
    states = [(float(m[1]), m[2]) for line in lines if (m := STATE_LINE.search(line))]
    held_s, resumed_s = _held(states)
    launcher = [line for line in lines if line.startswith("launch: ")
                and ("died" in line or "restarted" in line)]
    return {"transport": "ros2", "spec": spec, "exit_code": done.returncode,
            "result": "completed" if done.returncode == 0 else "not completed",
            "held_s": held_s, "resumed_s": resumed_s,
            "sim_s": states[-1][0] if states else None, "launcher": launcher,
            "last_states": [s for _, s in states[-3:]], "wall_s": round(wall, 1),
            "replay": "quadmission launch config/launch/mission.yaml --transport ros2 "
                      f"--rtf 1 --fault {spec}"}


def main(argv: list[str] | None = None) -> int:
    p = bench_parser(__doc__, "recovery")
    p.add_argument("--skip-ros2", action="store_true", help="only the in-process flights")
    p.add_argument("--kill-at", type=float, default=200.0,
                   help="ros2: wall s (at --rtf 1) at which the navigation process dies")
    p.add_argument("--domain-id", type=int, default=93, help="ros2: ROS_DOMAIN_ID")
    p.add_argument("--timeout", type=float, default=3600.0, help="ros2: wall s at most")
    p.add_argument("--ros2-only", action="store_true",
                   help="fly only the ros2 run; keep the in-process runs already in --out")
    args = p.parse_args(argv)
    result: dict[str, Any] = {"arena": "contest (default)", "seed": 0, "runs": []}
    if args.ros2_only:
        kept = json.loads(args.out.read_text())
        clean = result["clean"] = kept["clean"]
        result["runs"] = [r for r in kept["runs"] if r["transport"] == "inproc"]
    else:
        clean = result["clean"] = fly_in_process(None)
        progress(f"clean: {clean['result']} in {clean['sim_s']:.1f} s simulated")
    for name, spec in IN_PROCESS if not args.ros2_only else ():
        run = {"name": name, **fly_in_process(spec)}
        result["runs"].append(run)
        progress(f"{name}: {run['result']}, held {run['held_s']} s, resumed {run['resumed_s']} s")
        write_result(args.out, result, indent=1)
    if not args.skip_ros2:
        run = {"name": "navigation_respawned_ros2",
               **fly_ros2(args.kill_at, args.domain_id, args.timeout)}
        result["runs"].append(run)
        progress(f"ros2 navigation respawned: exit {run['exit_code']}, held {run['held_s']} s")
    for run in result["runs"]:
        if run["sim_s"] is not None:
            run["lost_s"] = round(run["sim_s"] - clean["sim_s"], 1)
            run["slowdown"] = round(run["sim_s"] / clean["sim_s"], 3)
    result["all_completed"] = all(r["result"] == "completed" for r in result["runs"])
    write_result(args.out, result, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
