"""One process of a launch over processes: a group of nodes, or the simulator.

Started by :mod:`runtime.processes.launcher` as ``python -m runtime.processes.child
SPEC_JSON`` (:class:`ProcessSpec`), on the transport the spec names (``ros2``: rclpy on
Fast DDS; :data:`TRANSPORTS`). A node process waits
for the first ``/clock`` (``use_sim_time``),
creates its nodes and spins them until one of them finishes (its exit code is the
process's) or SIGINT/SIGTERM. The simulator process builds the simulation around an
executor on the same transport and, every 2 ms of simulated time (``_TICK_HZ``), publishes
``/clock``, takes the samples that arrived and paces to ``rtf`` times real time. It waits
for the node processes' ``/clock`` subscriptions before it starts, so no simulated time
passes while they boot. A last line on stderr says why the process ended.

Lockstep: every node process reports the simulated time it has reached every
``ack_period_s`` (on ``/launch/<process>/clock``), and the simulator never runs more than
``max_lead_s`` ahead of the slowest report. A node process's clock thus lags the world's
by at most that bound however starved of CPU it is: a starved process slows the
simulated world down (the run's real-time factor drops) instead of seeing simulated time
jump past it. The bound is what a round trip through a node process can gain in
simulated time. It has to stay well under the FCU time sync's 10 ms RTT gate and near
its 1 ms deviation floor: a descheduled bridge sees its exchanges skewed by up to the
bound, and with a bound far above the gate its clock estimate loses convergence, it holds
the visual odometry back (a sample time on a wrong clock is worse than none) and the
FCU's position estimate times out. While it waits, the simulator sends the current
``/clock`` again every 0.1 s of host time: ``/clock`` is best effort (as rclcpp
subscribes it), and a process that lost the last samples could not catch up otherwise. A
node process answers such a repeat with its report at once: its reports are timed on
simulated time, which advances at most one /clock step while the simulator waits, and
the first ones can be lost while discovery matches the report's reader; without that
answer the launch would wait for a report that never comes.

A node process that died and is to be restarted (``respawn`` in the launch file) leaves
the lockstep: the launcher writes ``left NAME`` on the simulator's stdin
(``control_stdin``) and the simulator waits for it no more; the restarted process
(``rejoin``) makes its nodes at the simulated time it finds on ``/clock``, and its first
report, newer than any of the dead one's, takes it back.
"""

from __future__ import annotations

import json
import logging
import os
import signal
import sys
import time
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from interfaces import graph
from runtime.executor import DeterministicExecutor
from runtime.launch import (
    LaunchDescription,
    NodeSpec,
    SimulatorSpec,
    finished,
    finishing,
    first_finished,
    launch,
)
from runtime.node import Node
from runtime.processes.callback_stats import stats_folder
from runtime.processes.executor import ClockedExecutor, ParameterMirror, ProcessTransport
from runtime.processes.lockstep import clock_cdr, clock_ns
from runtime.processes.respawn import DEFAULT_RESPAWN_MAX, RespawnPolicy
from runtime.transport import Endpoint, SampleCallback

__all__ = ["TRANSPORTS", "ProcessSpec", "main"]

#: exit codes of a process besides its nodes' own
EXIT_NO_CLOCK = 3  # no /clock arrived in time
EXIT_NO_PEERS = 4  # the simulator's subscribers did not show up in time
EXIT_STALLED = 5  # a node process sent no report for stall_timeout_s while it was waited for
_TICK_HZ = 500.0  # /clock rate [Hz of simulated time]: a step of 2 ms, the report period
_WAIT_S = 0.01  # simulator: longest wait for a lagging process's report [s]
_CLOCK_REPEAT_S = 0.1  # simulator: /clock sent again after waiting this long [s, host]
_SIMULATOR_CLOCK = "/simulator_clock"  # the node of the simulator's /clock and its reports


@dataclass(frozen=True)
class ProcessSpec:
    """What one child process runs; passed as JSON on its command line."""

    name: str
    nodes: tuple[Mapping[str, Any], ...] = ()
    simulator: Mapping[str, Any] | None = None
    transport: str = "ros2"  # a key of TRANSPORTS
    domain_id: int = 0
    loopback_only: bool = True  # discovery and traffic stay on this machine
    use_sim_time: bool = True
    config_dir: str | None = None
    rtf: float = 1.0  # simulator: simulated seconds per wall second (0: as fast as it can)
    duration_s: float = 600.0  # simulator: simulated time limit
    clock_subscribers: int = 0  # simulator: wait for this many /clock readers first
    followers: tuple[str, ...] = ()  # simulator: the node processes it must not outrun
    max_lead_s: float = 0.005  # simulator: how far it may run ahead of them [s simulated]
    ack_period_s: float = 0.002  # node process: reports its time this often [s simulated]
    startup_timeout_s: float = 120.0
    stall_timeout_s: float = 120.0  # simulator: gives up on a node process silent this long [s]
    log_level: str = "INFO"
    respawn_delay_s: float | None = None  # node process: started again when it dies (None: not)
    respawn_max: int = DEFAULT_RESPAWN_MAX  # ... at most this many times over the launch
    rejoin: bool = False  # node process: a restart, joining a running launch (below)
    control_stdin: bool = False  # simulator: the launcher's lines come on stdin (_ControlPipe)

    def __post_init__(self) -> None:
        if self.transport not in TRANSPORTS:
            raise ValueError(f"transport {self.transport!r}: expected one of "
                             f"{', '.join(sorted(TRANSPORTS))}")
        if not 0 < self.ack_period_s < self.max_lead_s:
            raise ValueError(f"ack_period_s {self.ack_period_s:g} must be positive and "
                             f"below max_lead_s {self.max_lead_s:g} (else the simulator "
                             "stalls between two reports)")

    def to_json(self) -> str:
        return json.dumps(asdict(self))

    @classmethod
    def from_json(cls, text: str) -> ProcessSpec:
        raw = json.loads(text)
        raw["nodes"] = tuple(raw.get("nodes") or ())
        raw["followers"] = tuple(raw.get("followers") or ())
        return cls(**raw)

    def respawn_policy(self) -> RespawnPolicy | None:
        """When this process is started again after it dies, or None."""
        if self.respawn_delay_s is None:
            return None
        return RespawnPolicy(self.respawn_delay_s, self.respawn_max)

    def make_transport(self) -> ProcessTransport:
        return TRANSPORTS[self.transport](self)


def _ros2(spec: ProcessSpec) -> ProcessTransport:
    from runtime.ros2.config import Ros2Config
    from runtime.ros2.transport import Ros2Transport
    return Ros2Transport(Ros2Config(spec.domain_id, spec.loopback_only), name=spec.name,
                         use_sim_time=spec.use_sim_time)


#: How a process makes its transport, by name (imported only when chosen).
TRANSPORTS: dict[str, Callable[[ProcessSpec], ProcessTransport]] = {"ros2": _ros2}


def _node_name(process: str) -> str:
    return "".join(c if c.isalnum() or c == "_" else "_" for c in process)


def _say(name: str, text: str) -> None:
    print(f"[{name}] {text}", file=sys.stderr, flush=True)


def _config_dir(spec: ProcessSpec) -> Any:
    from runtime.executor import DEFAULT_CONFIG_DIR
    return Path(spec.config_dir) if spec.config_dir else DEFAULT_CONFIG_DIR


def _start_nodes(spec: ProcessSpec, ex: ClockedExecutor,
                 transport: ProcessTransport) -> list[Node]:
    """Create the group's nodes, and its lockstep reporter under ``use_sim_time``."""
    description = LaunchDescription(tuple(NodeSpec(**dict(n)) for n in spec.nodes))
    for node_spec in description.nodes:  # imports first: seconds, before any clock counts
        node_spec.resolve_factory()
    ex.catch_up()
    nodes = launch(description, ex)
    if isinstance(transport, ParameterMirror):  # declared on the transport's nodes too
        for node in nodes:
            transport.mirror_parameters(node)
    if spec.use_sim_time:
        reports = graph.LAUNCH_CLOCK_REPORT
        ex.report_reached(transport.create_writer(Endpoint(
            reports.name_for(spec.name), reports.type, reports.qos,
            node=f"/launch_{_node_name(spec.name)}_clock")), spec.ack_period_s)
    return nodes


def run_nodes(spec: ProcessSpec) -> int:
    """A node group: follow /clock, spin until a node finishes or a signal comes.

    At the launch's start the nodes are made at time 0 (the simulator waits for every
    group's /clock subscription). A restart (``rejoin``) joins a launch whose clock runs:
    it waits for /clock first and makes its nodes at that time (made at 0, their timers
    would catch up on every period since), fresh, with their parameters; what they knew
    comes back from the topics. Its first report brings it back into the lockstep."""
    transport = spec.make_transport()
    ex = ClockedExecutor(transport, use_sim_time=spec.use_sim_time,
                         config_dir=_config_dir(spec))
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: ex.stop())
    stats_to = None if spec.use_sim_time else stats_folder()
    stats = None if stats_to is None else ex.keep_callback_stats()
    rejoin = spec.rejoin and spec.use_sim_time
    nodes = [] if rejoin else _start_nodes(spec, ex, transport)  # at 0: the simulator waits
    if not ex.wait_for_clock(spec.startup_timeout_s):
        if ex.stopping:
            return 0
        _say(spec.name, f"no {graph.CLOCK.name} after {spec.startup_timeout_s:g} s; is the "
                        "simulator running on this domain?")
        return EXIT_NO_CLOCK
    if rejoin:
        nodes = _start_nodes(spec, ex, transport)
        _say(spec.name, f"restarted: nodes made at {ex.now().nanoseconds / 1e9:.3f} s "
                        "simulated")
    try:
        watched = finishing(nodes)
        ex.spin(until=lambda: first_finished(watched) is not None)
    finally:  # what a node holds outside the graph is let go: a bag's index, a server
        for node in reversed(nodes):
            node.destroy_node()
        if stats is not None and stats_to is not None:
            stats.write(stats_to, spec.name)
    done = finished(nodes)
    if done is None:
        return 0
    assert done.exit_code is not None
    _say(spec.name, done.exit_reason)
    return done.exit_code


class _ControlPipe:
    """Lines from the launcher on a file descriptor (the simulator's stdin), read without
    blocking."""

    def __init__(self, fd: int) -> None:
        self.fd, self._buffer, self._open = fd, b"", True
        os.set_blocking(fd, False)

    def lines(self) -> list[str]:
        if not self._open:
            return []
        try:
            chunk = os.read(self.fd, 4096)
        except BlockingIOError:
            return []
        if not chunk:  # the launcher is gone
            self._open = False
            return []
        *whole, self._buffer = (self._buffer + chunk).split(b"\n")
        return [line.decode(errors="replace").strip() for line in whole]


def run_simulator(spec: ProcessSpec) -> int:
    """The simulated world: publishes /clock, paced to ``rtf``."""
    assert spec.simulator is not None
    transport = spec.make_transport()
    ex = DeterministicExecutor(transport=transport, config_dir=_config_dir(spec))
    stop = {"now": False}

    def on_signal(*_: Any) -> None:
        stop["now"] = True
        transport.wake()

    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, on_signal)
    simulation = SimulatorSpec(str(spec.simulator["factory"]),
                               dict(spec.simulator.get("parameters") or {})).build(ex)
    if isinstance(transport, ParameterMirror):
        for node in list(ex.context.nodes):
            transport.mirror_parameters(node)
    clock_pub = transport.create_writer(Endpoint(graph.CLOCK.name, graph.CLOCK.type,
                                                 graph.CLOCK.qos, node=_SIMULATOR_CLOCK))
    reached = dict.fromkeys(spec.followers, 0)
    left: dict[str, int] = {}  # followers whose process died (to be restarted): last report
    control = _ControlPipe(sys.stdin.fileno()) if spec.control_stdin else None

    def on_ack(who: str) -> SampleCallback:
        def note(data: bytes, _request_id: Any) -> None:  # taken by transport.dispatch
            t = clock_ns(data)
            if who in left:  # its replacement's first report, newer than any of the dead's
                if t <= left[who]:
                    return
                del left[who]
                _say(spec.name, f"{who} rejoined the lockstep at {t / 1e9:.3f} s simulated")
            reached[who] = max(reached.get(who, 0), t)
        return note

    def take_control() -> None:
        """The launcher's lines: ``left NAME`` when a follower's process died and is to be
        started again: not waited for until its replacement reports."""
        assert control is not None
        for line in control.lines():
            verb, _, who = line.partition(" ")
            if verb == "left" and who in reached:
                left[who] = reached.pop(who)
                _say(spec.name, f"{who} left the lockstep at {ex.now().nanoseconds / 1e9:.3f} "
                                "s simulated (its process died); waiting for it no more")

    reports = graph.LAUNCH_CLOCK_REPORT
    for follower in spec.followers:
        transport.create_reader(Endpoint(reports.name_for(follower), reports.type,
                                         reports.subscriber_qos, node=_SIMULATOR_CLOCK),
                                on_ack(follower))
    max_lead_ns = round(spec.max_lead_s * 1e9)
    deadline = time.monotonic() + spec.startup_timeout_s
    while clock_pub.matched_count() < spec.clock_subscribers and not stop["now"]:
        if time.monotonic() > deadline:
            _say(spec.name, f"only {clock_pub.matched_count()} of "
                            f"{spec.clock_subscribers} node processes subscribed to "
                            f"{graph.CLOCK.name} after {spec.startup_timeout_s:g} s")
            return EXIT_NO_PEERS
        transport.wait(0.05)
        transport.dispatch()
    if stop["now"]:
        return 0
    wall0 = time.perf_counter()
    sim0 = ex.now().nanoseconds
    stalled: list[str] = []  # the node processes that stopped reporting, once given up on

    def tick(t_ns: int) -> None:
        clock = clock_cdr(t_ns)
        clock_pub.write(clock)
        transport.dispatch()
        waiting_since = time.monotonic()
        repeat_at = waiting_since + _CLOCK_REPEAT_S
        while reached and min(reached.values()) < t_ns - max_lead_ns and not stop["now"]:
            transport.wait(_WAIT_S)  # a node process lags: let it catch up
            transport.dispatch()
            ex.spin_until(ex.now().nanoseconds)  # its reports, taken at this time
            if control is not None:  # or it died, and the launcher said so
                take_control()
            now = time.monotonic()
            if now >= repeat_at:  # /clock is best effort: a process that
                clock_pub.write(clock)  # lost the last samples would wait forever
                repeat_at = now + _CLOCK_REPEAT_S
            if now - waiting_since > spec.stall_timeout_s:  # said, not waited on forever
                late = ", ".join(f"{who} (at {t / 1e9:.3f} s)" for who, t in reached.items()
                                 if t < t_ns - max_lead_ns)
                _say(spec.name, f"stalled at {t_ns / 1e9:.3f} s simulated: no report from "
                                f"{late} for {spec.stall_timeout_s:g} s")
                stalled.append(late)
                stop["now"] = True
        if spec.rtf > 0:
            ahead = (t_ns - sim0) / 1e9 / spec.rtf - (time.perf_counter() - wall0)
            if ahead > 0:
                time.sleep(ahead)

    result = simulation.run(spec.duration_s, stop=lambda: stop["now"], tick=tick,
                            tick_hz=_TICK_HZ)
    sim_s, wall_s = (ex.now().nanoseconds - sim0) / 1e9, time.perf_counter() - wall0
    _say(spec.name, f"ran {sim_s:.3f} s simulated in {wall_s:.3f} s "
                    f"(real-time factor {sim_s / max(wall_s, 1e-9):.2f})")
    if stalled:
        return EXIT_STALLED
    if stop["now"]:
        return 0
    _say(spec.name, result.reason)
    return result.exit_code


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 1:
        print("usage: python -m runtime.processes.child SPEC_JSON", file=sys.stderr)
        return 2
    spec = ProcessSpec.from_json(args[0])
    logging.basicConfig(level=spec.log_level, stream=sys.stderr,
                        format=f"[{spec.name}] %(levelname)s %(message)s")
    if logging.getLevelName(spec.log_level) > logging.DEBUG:  # as `quadmission` without -v:
        logging.getLogger("transitions").setLevel(logging.WARNING)  # no line per callback
    return run_simulator(spec) if spec.simulator is not None else run_nodes(spec)


if __name__ == "__main__":
    sys.exit(main())
