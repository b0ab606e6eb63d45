"""A launch over processes: each process group (and the simulator) in its own process.

:func:`run_launch` starts the children (:mod:`runtime.processes.child`), then watches them:
the first to exit ends the launch (a finishing node's process exiting 0 after the
mission, or any process dying), the others get SIGINT, then SIGKILL if they do not stop
within a grace period. ``kills`` kill chosen processes on purpose (a fault: a node's
process dies) at given wall-clock times from the start; their death ends nothing.
Ctrl-C (or SIGTERM) does the same and returns 130. What ended the launch is said in one
line, naming the process.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

from runtime.launch import LaunchDescription
from runtime.processes.child import ProcessSpec

__all__ = ["LaunchResult", "process_specs", "run_launch"]

_GRACE_S = 5.0
_PROJECT_ROOT = Path(__file__).resolve().parents[2]
EXIT_INTERRUPTED = 130


@dataclass(frozen=True)
class LaunchResult:
    exit_code: int
    reason: str


def process_specs(description: LaunchDescription, **common: Any) -> list[ProcessSpec]:
    """The simulator (first, if any), then one spec per process group, in file order."""
    groups: dict[str, list[dict[str, Any]]] = {}
    for spec in description.nodes:
        if not isinstance(spec.factory, str):
            raise ValueError(f"node {spec.name or spec.factory}: a launch over processes needs the "
                             "factory as 'package.module:Class'")
        groups.setdefault(spec.process_name(), []).append(
            {"factory": spec.factory, "name": spec.name, "namespace": spec.namespace,
             "parameters": dict(spec.parameters), "remappings": dict(spec.remappings)})
    specs = []
    if description.simulator is not None:
        sim = description.simulator
        specs.append(ProcessSpec("simulator", simulator={
            "factory": sim.factory, "parameters": dict(sim.parameters)},
            clock_subscribers=len(groups), followers=tuple(groups), **common))
    specs += [ProcessSpec(name, nodes=tuple(nodes), **common) for name, nodes in groups.items()]
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


def run_launch(specs: list[ProcessSpec], *, log: TextIO = sys.stderr,
               kills: Sequence[tuple[float, str]] = ()) -> LaunchResult:
    """Start every process, wait for the first to end, stop the rest. ``kills``: (wall
    seconds after the start, process name) to SIGKILL then, as a fault."""
    names = [spec.name for spec in specs]
    for _, name in kills:
        if name not in names:
            raise ValueError(f"no process {name!r} to kill (processes: {', '.join(names)})")
    pending = sorted(kills)
    killed: set[str] = set()
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(
        p for p in (str(_PROJECT_ROOT), env.get("PYTHONPATH", "")) if p)
    procs: dict[str, subprocess.Popen[bytes]] = {}
    interrupted = {"yes": False}
    previous = {sig: signal.signal(sig, lambda *_: interrupted.update(yes=True))
                for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        for spec in specs:
            procs[spec.name] = subprocess.Popen(
                [sys.executable, "-m", "runtime.processes.child", spec.to_json()], env=env)
            print(f"launch: started {spec.name} (pid {procs[spec.name].pid})", file=log,
                  flush=True)
        started = time.monotonic()
        while True:
            while pending and time.monotonic() - started >= pending[0][0]:
                _, name = pending.pop(0)
                procs[name].kill()
                killed.add(name)
                print(f"launch: killed {name} (pid {procs[name].pid}): a node_stop fault",
                      file=log, flush=True)
            if interrupted["yes"]:
                _stop_all(procs)
                return LaunchResult(EXIT_INTERRUPTED, "interrupted (Ctrl-C)")
            for name, proc in procs.items():
                code = proc.poll()
                if code is not None and name not in killed:
                    _stop_all(procs)
                    how = (f"exited with code {code}" if code >= 0
                           else f"was killed by signal {-code}")
                    verdict = "finished" if code == 0 else "died"
                    return LaunchResult(code if code >= 0 else 1,
                                        f"process {name!r} (pid {proc.pid}) {how} ({verdict})")
            time.sleep(0.1)
    finally:
        _stop_all(procs)
        for sig, handler in previous.items():
            signal.signal(sig, handler)
