"""The contest mission in real time: ``quadmission vehicle`` on the wall clock, the
companion (``config/launch/companion.yaml``, unchanged) and an operator beside it, each in
processes of their own on a ROS domain of the run's own, scored against the vehicle's
ground truth as ``quadmission sim`` scores an embedded run.

:func:`fly_realtime` (``quadmission fly-realtime``, ``make fly-realtime``):

1. starts ``quadmission vehicle --out OUT/vehicle`` (at nice :data:`VEHICLE_NICE` where
   allowed: it stands for hardware with CPUs of its own) and waits until it is up;
2. starts ``quadmission launch`` of ``companion.yaml`` with ``--transport ros2
   --wall-clock``, given the arena the vehicle flies (``arena:`` on the factories that
   take it: what the contest publishes before the run; the node list is the file's);
3. starts the operator (``config/launch/operator.yaml``: the simulated operator, who
   sends START and the landing sequence on ``/mission/command``) and :class:`MissionRecorder`,
   which writes what the mission says on ``/mission/state`` and ``/mission/events`` to
   ``OUT/mission.json`` as it comes;
4. waits for the companion's launch to end (the mission completed, stopped, or its
   ``until_state`` reached) or ``timeout_s``, lets the vehicle settle, stops the operator
   and the vehicle with SIGINT (the vehicle writes its truth), and writes
   ``OUT/report.json`` (:func:`realtime_report`), with each companion and operator node's
   callback timing (``callbacks``: take delay, latency and run time, p50/p99/max, from
   ``OUT/callbacks/``; :mod:`runtime.processes.callback_stats`).

The companion's stamps are on the host's clock; the vehicle's ``host_ns_at_sim_zero``
turns them into its simulated time, where its true trajectory is. Logs: ``OUT/*.log``.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import IO, Any

import yaml

from fsm.mission_machine import EventKind
from interfaces import graph
from quadmission.errors import OptionsError
from quadmission.evaluation.mission import landing, score, touchdown_summary
from quadmission.evaluation.tracking import rounded
from quadmission.reports.report import write_report
from quadmission.scenarios.mission.scenario import target_robot
from quadmission.vehicle.run import VehicleOptions
from quadmission.vehicle.truth import VehicleTruth, load_truth
from runtime import Node, Time
from runtime.processes.callback_stats import STATS_VARIABLE, merge
from sim.arena import ArenaSpec, load_arena

__all__ = ["MISSION_JSON", "MissionRecorder", "RealtimeOptions", "fly_realtime",
           "realtime_report", "recorder"]

ROOT = Path(__file__).resolve().parents[3]
COMPANION_YAML = ROOT / "config" / "launch" / "companion.yaml"
OPERATOR_YAML = ROOT / "config" / "launch" / "operator.yaml"
MISSION_JSON = "mission.json"
CALLBACKS = "callbacks"  # OUT/callbacks/: each process's callback statistics
_ARENA_FACTORIES = "quadmission.scenarios."  # factories that take the `arena` parameter
_MISSION_FACTORY = "quadmission.scenarios.mission.launch:mission"
_VEHICLE_UP_S = 300.0  # the vehicle's start, imports and scene included [s, host]
_SETTLE_S = 3.0  # after the mission: the vehicle at rest before its truth is written [s]
_STOP_S = 30.0  # a process's grace after SIGINT [s]
#: The vehicle's nice value: it stands for hardware with CPUs of its own, so on a shared host
#: it goes before the companion and whatever else runs there; starved, it would fall behind
#: real time and its late data would be counted against the companion. Kept at the
#: default where the user may not raise a priority (not root, no CAP_SYS_NICE), and said.
VEHICLE_NICE = -5


class MissionRecorder(Node):
    """Writes the mission's states and events (``/mission/state``, ``/mission/events``,
    stamps on the companion's clock) to ``folder/mission.json`` as they come: an
    observer of the graph, in the app layer; it sees nothing the operator could not."""

    def __init__(self, *, folder: str, **kwargs: Any) -> None:
        super().__init__("mission_recorder", **kwargs)
        self.path = Path(folder) / MISSION_JSON
        self.states: list[dict[str, Any]] = []
        self.events: list[dict[str, Any]] = []
        self.last: dict[str, Any] = {}
        s, e = graph.MISSION_STATE, graph.MISSION_EVENTS
        self.create_subscription(s.type, s.name, self._on_state, s.subscriber_qos)
        self.create_subscription(e.type, e.name, self._on_event, e.subscriber_qos)

    def _on_state(self, msg: Any) -> None:
        last = {"state": str(msg.state), "score": int(msg.score),
                "sequence": [int(p) for p in msg.landing_sequence],
                "pads_landed": [int(p) for p in msg.pads_landed],
                "pads_skipped": [int(p) for p in msg.pads_skipped],
                "stop_reason": str(msg.stop_reason)}
        if not self.states or self.states[-1]["state"] != last["state"]:
            self.states.append({"stamp_ns": Time.from_msg(msg.header.stamp).nanoseconds,
                                "state": last["state"]})
        if last != self.last:
            self.last = last
            self._write()

    def _on_event(self, msg: Any) -> None:
        self.events.append({"stamp_ns": Time.from_msg(msg.header.stamp).nanoseconds,
                            "kind": EventKind(int(msg.kind)).name, "marker_id": int(msg.marker_id),
                            "state": str(msg.state), "message": str(msg.message)})
        self._write()

    def _write(self) -> None:
        tmp = self.path.with_suffix(".tmp")
        tmp.write_text(json.dumps({"last": self.last, "states": self.states,
                                   "events": self.events}, indent=1), encoding="utf-8")
        tmp.replace(self.path)


def recorder(*, parameter_overrides: dict[str, Any] | None = None,
             **kwargs: Any) -> MissionRecorder:
    """The launch factory: ``folder`` (a launch parameter) is where mission.json goes."""
    rest = dict(parameter_overrides or {})
    folder = rest.pop("folder", None)
    if folder is None or rest:
        raise OptionsError(f"mission_recorder takes 'folder' alone, got {sorted(rest)}"
                           if rest else "mission_recorder: give it 'folder'")
    return MissionRecorder(folder=str(folder), **kwargs)


def realtime_report(arena: ArenaSpec, truth: VehicleTruth,
                    record: dict[str, Any]) -> dict[str, Any]:
    """The run judged against the vehicle's truth: each LANDED event's touchdown (its
    stamp turned into the vehicle's simulated time), the score at the target robot's
    true table, the vehicle's crash, failsafes and how far it fell behind real time."""
    target = target_robot(arena, None)
    table = next(r.points_table for r in arena.robots if r.marker_id == target)
    landed = [(truth.sim_time_s(e["stamp_ns"]), e["marker_id"]) for e in record["events"]
              if e["kind"] == EventKind.LANDED.name]
    landings = [landing(arena, pad, t, truth.trajectory) for t, pad in landed]
    last = record.get("last", {})
    state = last.get("state", "never seen")
    summary = truth.summary
    completed = state == "completed" and summary["crash"] is None
    inside = sum(d.inside for d in landings)
    sequence = last.get("sequence", [])
    ok = (completed and bool(sequence) and inside == len(landings) == len(sequence))
    verdict = (f"{'completed' if completed else 'NOT completed'} ({state}): score "
               f"{score(landings, table)}, {inside}/{len(landings)} landings inside"
               + (f"; {last['stop_reason']}" if last.get("stop_reason") else ""))
    return {
        "scenario": "mission_realtime", "arena": arena.name, "seed": summary["seed"],
        "target_robot": target, "verdict": verdict, "ok": ok,
        "result": "completed" if completed else "not_completed", "final_state": state,
        "score": score(landings, table), "max_score": sum(table.values()),
        "mission_score": last.get("score"), "sequence": sequence,
        "landings": [d.to_json() for d in landings], **touchdown_summary(landings),
        "pads_skipped": last.get("pads_skipped", []),
        "crashed": summary["crash"] is not None, "crash": summary["crash"],
        "fcu_failsafes": summary["failsafes"], "touchdowns": summary["touchdowns"],
        "states": [{"t_s": rounded(truth.sim_time_s(s["stamp_ns"]), 3), "state": s["state"]}
                   for s in record.get("states", [])],
        "vehicle": {k: summary[k] for k in ("rtf", "rtf_achieved", "sim_time_s",
                                            "wall_time_s", "cpu_time_s", "behind",
                                            "setpoints", "vision")},
    }


@dataclass(frozen=True)
class RealtimeOptions:
    """What ``quadmission fly-realtime`` takes: the vehicle's options (its ``out`` is
    replaced by ``OUT/vehicle``; its domain is the run's) and the companion's."""

    out: Path
    vehicle: VehicleOptions
    until_state: str | None = None  # end once the mission enters it (a short check)
    timeout_s: float = 1800.0  # [s of host time] the companion's launch at most
    settle_s: float = _SETTLE_S  # [s of host time] the vehicle runs on after the companion
    #: a phrase of the vehicle's log ("touchdown at") that ends the settle as soon as the
    #: vehicle says it after the companion stopped; ``settle_s`` is then the bound. On a
    #: busy host the vehicle falls behind the host's clock: a fixed host time may be too
    #: few simulated seconds for what the vehicle has still to do
    settle_until: str | None = None
    vehicle_nice: int = VEHICLE_NICE  # the vehicle's process priority (nice), if allowed
    #: the companion's and the operator's processes' nice (0: as any program; a flight stack
    #: that shares its computer with other work is given a higher priority, if allowed)
    companion_nice: int = 0
    #: CPUs the companion's and the operator's processes may run on (as ``taskset -c``), and
    #: the vehicle's (None: any); a budget measured on one core pins them there
    companion_cpus: tuple[int, ...] | None = None
    vehicle_cpus: tuple[int, ...] | None = None
    companion: Path = COMPANION_YAML
    say: Callable[[str], None] = field(default=lambda _line: None, compare=False)


def _with_arena(launch_yaml: Path, arena_file: Path, out: Path,
                extra: dict[str, dict[str, Any]] | None = None) -> Path:
    """``launch_yaml`` with ``arena: arena_file`` on each node whose factory takes it (and
    ``extra[factory]`` added); its node list unchanged. Written into ``out``."""
    doc = yaml.safe_load(launch_yaml.read_text(encoding="utf-8"))
    for node in doc.get("nodes") or []:
        params = dict(node.get("parameters") or {})
        if str(node["factory"]).startswith(_ARENA_FACTORIES):
            params["arena"] = str(arena_file)
        params |= (extra or {}).get(str(node["factory"]), {})
        if params:
            node["parameters"] = params
    path = out / launch_yaml.name
    path.write_text(yaml.safe_dump(doc, sort_keys=False), encoding="utf-8")
    return path


def _cli(*args: str) -> list[str]:
    return [sys.executable, "-m", "quadmission.cli", *args]


def _start(argv: list[str], log: IO[str], nice: int = 0, cpus: tuple[int, ...] | None = None,
           env_extra: dict[str, str] | None = None) -> subprocess.Popen[str]:
    env = dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"), **(env_extra or {}))
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT), env.get("PYTHONPATH", "")) if p)

    def prioritise() -> None:  # in the child, before it runs: its threads and children
        with contextlib.suppress(PermissionError):  # inherit both
            os.setpriority(os.PRIO_PROCESS, 0, nice)
        if cpus is not None:
            os.sched_setaffinity(0, cpus)  # as taskset -c

    return subprocess.Popen(argv, cwd=ROOT, stdout=log, stderr=subprocess.STDOUT, text=True,
                            env=env, start_new_session=True,
                            preexec_fn=prioritise if nice or cpus is not None else None)


def _stop(proc: subprocess.Popen[str]) -> int:
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(_STOP_S)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    return proc.returncode


def fly_realtime(options: RealtimeOptions) -> dict[str, Any]:
    """Fly the mission in real time (see the module docstring); the report."""
    out = options.out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    vehicle = replace(options.vehicle, out=out / "vehicle")
    ros = ["--domain-id", str(vehicle.domain_id)]
    logs = {name: (out / f"{name}.log").open("w", encoding="utf-8")
            for name in ("vehicle", "companion", "operator")}
    procs: dict[str, subprocess.Popen[str]] = {}
    try:
        procs["vehicle"] = _start(_cli("vehicle", *vehicle.argv()), logs["vehicle"],
                                  options.vehicle_nice, options.vehicle_cpus)
        nice = os.getpriority(os.PRIO_PROCESS, procs["vehicle"].pid)
        options.say(f"vehicle started (pid {procs['vehicle'].pid}, nice {nice}"
                    + ("" if nice == options.vehicle_nice else
                       f": not allowed to set {options.vehicle_nice}")
                    + f"); log {out / 'vehicle.log'}")
        _wait_up(procs["vehicle"], out / "vehicle.log")
        arena_file = vehicle.out / "arena.yaml"
        until = {_MISSION_FACTORY: {"until_state": options.until_state}} \
            if options.until_state else None
        companion = _with_arena(options.companion, arena_file, out, until)
        operator = _with_arena(OPERATOR_YAML, arena_file, out)
        doc = yaml.safe_load(operator.read_text(encoding="utf-8"))
        doc["nodes"].append({"factory": f"{__name__}:recorder", "process": "operator",
                             "parameters": {"folder": str(out)}})
        operator.write_text(yaml.safe_dump(doc, sort_keys=False), encoding="utf-8")
        wall = ["--transport", "ros2", "--wall-clock", *ros]
        shutil.rmtree(out / CALLBACKS, ignore_errors=True)  # an earlier run's, not merged
        timed = {STATS_VARIABLE: str(out / CALLBACKS)}  # every callback, per node
        procs["companion"] = _start(_cli("launch", str(companion), *wall), logs["companion"],
                                    options.companion_nice, options.companion_cpus, timed)
        procs["operator"] = _start(_cli("launch", str(operator), *wall), logs["operator"],
                                   options.companion_nice, options.companion_cpus, timed)
        options.say(f"companion (pid {procs['companion'].pid}) and operator (pid "
                    f"{procs['operator'].pid}) started; logs in {out}")
        deadline = time.monotonic() + options.timeout_s
        while procs["companion"].poll() is None and time.monotonic() < deadline:
            if procs["vehicle"].poll() is not None:
                break  # crashed, or stopped from outside
            time.sleep(0.5)
        said = (out / "vehicle.log").stat().st_size
        companion_code = _stop(procs["companion"])
        _settle(procs["vehicle"], out / "vehicle.log", said, options)
    finally:
        for proc in reversed(list(procs.values())):
            _stop(proc)
        for log in logs.values():
            log.close()
    record = json.loads((out / MISSION_JSON).read_text(encoding="utf-8")) \
        if (out / MISSION_JSON).is_file() else {"events": [], "states": []}
    report = realtime_report(load_arena(vehicle.out / "arena.yaml"), load_truth(vehicle.out),
                             record)
    report["companion_exit_code"] = companion_code
    report["callbacks"] = merge(out / CALLBACKS) if (out / CALLBACKS).is_dir() else {}
    report["until_state"] = options.until_state
    write_report(out, report)
    return report


def _settle(vehicle: subprocess.Popen[str], log: Path, said: int,
            options: RealtimeOptions) -> None:
    """``options.settle_s`` of host time, or until the vehicle's log says
    ``options.settle_until`` after its first ``said`` bytes (or the vehicle ends)."""
    deadline = time.monotonic() + options.settle_s
    while time.monotonic() < deadline and vehicle.poll() is None:
        if options.settle_until is not None and _says(log, options.settle_until, said):
            time.sleep(_SETTLE_S)  # at rest on its pad before the truth is written
            return
        time.sleep(min(0.5, max(0.0, deadline - time.monotonic())))


def _says(log: Path, phrase: str, since: int = 0) -> bool:
    """Whether the vehicle's ``log`` says ``phrase`` after its first ``since`` bytes."""
    with log.open("rb") as lines:
        lines.seek(since)
        return phrase.encode() in lines.read()


def _wait_up(proc: subprocess.Popen[str], log: Path) -> None:
    """Until the vehicle says it is up (its scene built, on the graph)."""
    deadline = time.monotonic() + _VEHICLE_UP_S
    while not _says(log, "vehicle up on ROS domain"):
        if proc.poll() is not None:
            raise OptionsError(f"the vehicle ended before it was up (exit code "
                               f"{proc.returncode}): {log.read_text()[-2000:]}")
        if time.monotonic() > deadline:
            raise OptionsError(f"the vehicle was not up after {_VEHICLE_UP_S:g} s ({log})")
        time.sleep(0.2)
