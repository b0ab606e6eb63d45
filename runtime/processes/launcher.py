"""A launch over processes: each process group (and the simulator) in its own process.

:func:`run_launch` starts the children (:mod:`runtime.processes.child`), then watches them:
the first to exit ends the launch (a finishing node's process exiting 0 after the
mission, or any process dying), the others get SIGINT, then SIGKILL if they do not stop
within a grace period. ``kills`` kill chosen processes on purpose (a fault: a node's
process dies) at given wall-clock times from the start; their death ends nothing.
Ctrl-C (or SIGTERM) does the same and returns 130. What ended the launch is said in one
line, naming the process.

A process whose launch file says ``respawn: true`` is started again when it dies, after
its ``respawn_delay``, at most ``respawn_max`` times (:mod:`runtime.processes.respawn`);
each death and restart is logged with the exit code or signal (``launch: navigation (pid
1234) died: killed by SIGKILL; restarting in 2.0 s (1 of 3)``), and the simulator is told
on its stdin (``left NAME``) so that it stops waiting for the dead process in the
lockstep.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, TextIO

from runtime.launch import LaunchDescription, NodeSpec
from runtime.processes.child import ProcessSpec
from runtime.processes.respawn import DEFAULT_RESPAWN_MAX, RespawnPolicy, Respawns, exit_text

__all__ = ["LaunchResult", "process_specs", "run_launch"]

_GRACE_S = 5.0
_PROJECT_ROOT = Path(__file__).resolve().parents[2]
EXIT_INTERRUPTED = 130


@dataclass(frozen=True)
class LaunchResult:
    exit_code: int
    reason: str


def _respawn_of(group: str, specs: list[NodeSpec]) -> dict[str, Any]:
    """The group's respawn keys for its ProcessSpec; nodes that give them must agree."""
    given = {(n.respawn_delay, n.respawn_max) for n in specs if n.respawn}
    if not given:
        if any(n.respawn_max is not None or n.respawn_delay for n in specs):
            raise ValueError(f"process {group!r}: respawn_delay or respawn_max without "
                             "respawn: true")
        return {}
    if len(given) > 1 or not all(n.respawn for n in specs):
        raise ValueError(f"process {group!r}: its nodes disagree on respawn, respawn_delay "
                         "or respawn_max (a process is restarted whole: say it once, the "
                         "same on every node of the group)")
    delay, count = given.pop()
    policy = RespawnPolicy(float(delay), DEFAULT_RESPAWN_MAX if count is None else count)
    return {"respawn_delay_s": policy.delay_s, "respawn_max": policy.max_count}


def process_specs(description: LaunchDescription, **common: Any) -> list[ProcessSpec]:
    """The simulator (first, if any), then one spec per process group, in file order."""
    groups: dict[str, list[NodeSpec]] = {}
    for spec in description.nodes:
        if not isinstance(spec.factory, str):
            raise ValueError(f"node {spec.name or spec.factory}: a launch over processes needs the "
                             "factory as 'package.module:Class'")
        groups.setdefault(spec.process_name(), []).append(spec)
    specs = []
    if description.simulator is not None:
        sim = description.simulator
        specs.append(ProcessSpec("simulator", simulator={
            "factory": sim.factory, "parameters": dict(sim.parameters)},
            clock_subscribers=len(groups), followers=tuple(groups), control_stdin=True,
            **common))
    for name, nodes in groups.items():
        entries = tuple({"factory": n.factory, "name": n.name, "namespace": n.namespace,
                         "parameters": dict(n.parameters), "remappings": dict(n.remappings)}
                        for n in nodes)
        specs.append(ProcessSpec(name, nodes=entries, **_respawn_of(name, nodes), **common))
    return specs


def _stop_all(procs: dict[str, subprocess.Popen[bytes]]) -> None:
    for proc in procs.values():
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
    deadline = time.monotonic() + _GRACE_S
    for proc in procs.values():
        try:
            proc.wait(max(0.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def _tell(proc: subprocess.Popen[bytes] | None, line: str) -> None:
    """A line to the simulator's control pipe (gone with the simulator: nothing to do)."""
    if proc is None or proc.stdin is None:
        return
    try:
        proc.stdin.write(line.encode() + b"\n")
        proc.stdin.flush()
    except (BrokenPipeError, OSError):
        pass


def run_launch(specs: list[ProcessSpec], *, log: TextIO = sys.stderr,
               kills: Sequence[tuple[float, str]] = ()) -> LaunchResult:
    """Start every process, wait for the first to end, stop the rest. ``kills``: (wall
    seconds after the start, process name) to SIGKILL then, as a fault.

    A process with a respawn policy (:meth:`ProcessSpec.respawn_policy`) that dies,
    killed on purpose or not, is started again after its delay, as a restart
    (``rejoin``); the simulator is told it left the lockstep at once, and takes it back
    at its replacement's first report. Its last allowed death, or any death of a process
    without one, ends the launch; a kill's death without one ends nothing."""
    names = [spec.name for spec in specs]
    for _, name in kills:
        if name not in names:
            raise ValueError(f"no process {name!r} to kill (processes: {', '.join(names)})")
    by_name = {spec.name: spec for spec in specs}
    respawns = Respawns({spec.name: policy for spec in specs
                         if (policy := spec.respawn_policy()) is not None})
    pending = sorted(kills)
    killed: set[str] = set()  # killed by a fault, their death not yet taken in
    restarts: dict[str, float] = {}  # dead processes to start again, and when
    gone: set[str] = set()  # killed by a fault, not to be restarted: the graph runs on
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(
        p for p in (str(_PROJECT_ROOT), env.get("PYTHONPATH", "")) if p)
    procs: dict[str, subprocess.Popen[bytes]] = {}
    interrupted = {"yes": False}
    previous = {sig: signal.signal(sig, lambda *_: interrupted.update(yes=True))
                for sig in (signal.SIGINT, signal.SIGTERM)}

    def start(spec: ProcessSpec) -> subprocess.Popen[bytes]:
        return subprocess.Popen(
            [sys.executable, "-m", "runtime.processes.child", spec.to_json()], env=env,
            stdin=subprocess.PIPE if spec.control_stdin else None)

    def say(line: str) -> None:
        print(f"launch: {line}", file=log, flush=True)

    try:
        for spec in specs:
            procs[spec.name] = start(spec)
            say(f"started {spec.name} (pid {procs[spec.name].pid})")
        simulator = next((procs[s.name] for s in specs if s.simulator is not None), None)
        started = time.monotonic()
        while True:
            now = time.monotonic()
            while pending and now - started >= pending[0][0]:
                _, name = pending.pop(0)
                if procs[name].poll() is None:
                    procs[name].kill()
                    killed.add(name)
                    say(f"killed {name} (pid {procs[name].pid}): a node_stop fault")
            for name, at in sorted(restarts.items()):
                if now >= at:
                    del restarts[name]
                    procs[name] = start(replace(by_name[name], rejoin=True))
                    say(f"restarted {name} (pid {procs[name].pid}) "
                        f"({respawns.used[name]} of {respawns.policies[name].max_count})")
            if interrupted["yes"]:
                _stop_all(procs)
                return LaunchResult(EXIT_INTERRUPTED, "interrupted (Ctrl-C)")
            for name, proc in procs.items():
                code = proc.poll()
                if code is None or name in restarts or name in gone:
                    continue
                was_killed = name in killed
                killed.discard(name)
                decision = respawns.ended(name, proc.pid, code, now,
                                          "a node_stop fault" if was_killed else "")
                if decision.restart_at is not None:
                    say(decision.line)
                    restarts[name] = decision.restart_at
                    _tell(simulator, f"left {name}")
                    continue
                if was_killed:  # a fault's kill without respawn: the graph runs on without it
                    gone.add(name)
                    say(decision.line)
                    continue
                _stop_all(procs)
                verdict = "finished" if code == 0 else "died"
                if name in respawns.policies and code != 0:
                    verdict += f"; not restarted: its {respawns.used[name]} restarts are used"
                return LaunchResult(code if code >= 0 else 1,
                                    f"process {name!r} (pid {proc.pid}) {exit_text(code)} "
                                    f"({verdict})")
            time.sleep(0.1)
    finally:
        _stop_all(procs)
        for sig, handler in previous.items():
            signal.signal(sig, handler)
