"""The ``quadmission`` command: one entry point, one subcommand per capability.

Errors are mapped here, at the boundary, once: the project's own errors (each package's
``errors.py`` base class) are bad input, said in one line with exit code 2; any other
exception is a bug and keeps its traceback. See :data:`EXIT_CODES`.
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import os
import signal
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

Handler = Callable[[argparse.Namespace], int]

EXIT_CODES = """\
exit codes:
  0    done (sim: the flight succeeded)
  1    the run finished but failed its check (sim: a crash, a mission not completed),
       or a bug in quadmission: an unexpected exception, printed with its traceback
  2    bad input: a wrong argument, or one of quadmission's own errors (an unknown YAML
       key, a value out of range, a YAML syntax error, an unknown message type...),
       said in one line on stderr; -v shows its traceback
  130  interrupted (Ctrl-C)
  141  the output pipe was closed (quadmission interfaces | head): stops quietly
"""
_STARTED_HOST_S = time.monotonic()  # when the command started: simulated time 0 under --rtf
EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130
EXIT_BROKEN_PIPE = 141  # 128 + SIGPIPE, what a C tool killed by the signal returns
#: [s] simulated: a launch file's simulator stops the launch after this long: the contest's
#: 900 s. (The former 600 s cut a mission over processes during its 10th landing.)
SIMULATOR_TIME_LIMIT_S = 900.0


def project_errors() -> tuple[type[Exception], ...]:
    """The base class of each package's own errors: what the CLI reports as bad input."""
    from flight_control.errors import FlightControlError
    from ground_station.errors import GroundStationError
    from interfaces.errors import InterfaceError
    from quadmission.errors import QuadmissionError
    from runtime.errors import RuntimeApiError
    from sim.errors import SimError
    from sim.fcu.errors import SchedulerError

    return (InterfaceError, RuntimeApiError, SimError, SchedulerError, FlightControlError,
            GroundStationError, QuadmissionError)


def _positive(what: str) -> Callable[[str], float]:
    """An argparse type: a positive, finite number (``what`` names it in errors)."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not {what}") from None
        if not 0.0 < value < math.inf:
            raise argparse.ArgumentTypeError(f"{text} must be a positive {what[2:]}")
        return value

    return parse


_positive_seconds = _positive("a number of seconds")
_positive_float = _positive("a number")


@dataclass(frozen=True)
class Command:
    """A subcommand: its name, one line of help, its arguments and what it runs."""

    name: str
    help: str
    add_arguments: Callable[[argparse.ArgumentParser], None]
    run: Handler


# -- interfaces ------------------------------------------------------------------------------
def _interfaces_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("name", nargs="?", help="a message, service or action to show (constants, "
                   "then each field's type, name and default; a service's request and "
                   "response, an action's goal, result and feedback), e.g. "
                   "px4_msgs/msg/VehicleOdometry or quadmission_interfaces/action/Reach")
    p.add_argument("--package", help="list only this package's types")
    p.add_argument("--graph", action="store_true",
                   help="list the companion graph instead (interfaces/graph.py): each topic, "
                        "service and action with its type, QoS and the nodes at its ends")
    p.add_argument("--markdown", action="store_true",
                   help="with --graph: as the docs page (docs/graph.md)")


def _interfaces_run(args: argparse.Namespace) -> int:
    import interfaces

    if args.graph or args.markdown:
        if not args.graph or args.name or args.package:
            from quadmission.errors import OptionsError

            raise OptionsError("interfaces --graph lists the whole graph: give it without a "
                               "type or --package (--markdown needs --graph)")
        from interfaces import graph

        sys.stdout.write(graph.markdown() if args.markdown else graph.text())
        return 0
    if args.name:
        parts = interfaces.interface_parts(args.name)
        for i, (part, typename) in enumerate(parts):
            if len(parts) > 1:  # the .srv/.action file's layout: parts between ---
                print(f"{'---' + chr(10) if i else ''}# {part}: {typename}")
            _print_type(typename)
        return 0
    for name in interfaces.registered_types(args.package):
        print(name)
    return 0


def _print_type(typename: str) -> None:
    import interfaces

    constants, fields = interfaces.describe(typename)
    for c in constants:
        print(f"{c.type} {c.name}={c.value}")
    if constants and fields:
        print()
    type_w = max((len(f.type) for f in fields), default=0)
    name_w = max((len(f.name) for f in fields), default=0)
    for f in fields:
        default = "" if f.nested else f"  {f.default!r}"
        print(f"{f.type:<{type_w}}  {f.name:<{name_w}}{default}".rstrip())


# -- launch ----------------------------------------------------------------------------------
def _launch_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", type=Path, help="launch YAML: nodes: [{factory, name, ...}], "
                   "e.g. config/launch/example.yaml")
    p.add_argument("--duration", type=_positive_seconds, default=None,
                   help="simulated seconds to run (default 10; with a simulator: the "
                        f"time limit, default {SIMULATOR_TIME_LIMIT_S:g})")
    p.add_argument("--config-dir", type=Path, default=None,
                   help="node YAMLs (default: config/, or $QUADMISSION_CONFIG_DIR)")
    p.add_argument("--transport", type=_transport, default="inproc",
                   help="inproc: every node in this process, in simulated time (default); "
                        "ros2: each process group in its own process, every node a real "
                        "rcl node (rclpy on Fast DDS)")
    p.add_argument("--domain-id", type=int, default=0,
                   help="ros2: the DDS domain id (ROS_DOMAIN_ID)")
    p.add_argument("--network", action="store_true",
                   help="ros2: discover and talk beyond this machine (default: "
                        "localhost only)")
    p.add_argument("--wall-clock", action="store_true",
                   help="ros2: nodes follow the host's clock, not /clock (a launch "
                        "without a simulator, e.g. the companion of a real vehicle)")
    p.add_argument("--out", type=Path, default=Path("runs/launch"),
                   help="folder for the recording (--record writes OUT/bag)")
    p.add_argument("--fault", action="append", default=[], metavar="SPEC",
                   help="inject a fault into the launch file's simulator, "
                        "KIND@T[:DURATION][,key=value...] (repeatable; node_stop under "
                        "--transport ros2 kills the node's process, T in wall seconds x rtf)")
    p.add_argument("--faults", type=Path, default=None, metavar="FILE.yaml",
                   help="inject the faults listed in this YAML file")
    _run_services_args(p)  # --rtf (ros2: default 1, real time), --record, --foxglove, --gcs


def _transport(value: str) -> str:
    """``--transport``'s value, naming the choices; the retired Cyclone DDS mapping is
    named with its replacement."""
    if value == "dds":
        raise argparse.ArgumentTypeError(
            "the Cyclone DDS transport 'dds' was retired; use --transport ros2 (rclpy on "
            "Fast DDS: the same processes, and real ROS 2 nodes)")
    if value not in ("inproc", "ros2"):
        raise argparse.ArgumentTypeError(f"{value!r} is not a transport: inproc or ros2")
    return value


def _refuse_ignored_services(args: argparse.Namespace, has_simulator: bool) -> None:
    """Run services a launch cannot attach are refused, not silently dropped. Under
    ``ros2`` they are nodes in a process of their own; around a launch file's simulator in
    process there is no page: there they are nodes of the launch file instead."""
    from quadmission.errors import OptionsError

    if not 0 <= args.domain_id <= 232:
        raise OptionsError(f"--domain-id {args.domain_id} is outside 0..232")
    processes = args.transport == "ros2"
    if processes or not has_simulator:
        return
    # in process, the recorder and the Foxglove bridge tap the executor around the
    # simulator as they do around a scenario; pacing and the page need the sim loop's parts
    asked = [flag for flag, on in (("--gcs", args.gcs), ("--rtf", args.rtf is not None)) if on]
    if asked:
        raise OptionsError(
            f"{' '.join(asked)}: not available with a launch file with a simulator, in "
            "process; add the nodes to the launch "
            "file instead (ground_station.recorder_node:BagRecorderNode with a 'folder', "
            "ground_station.foxglove_bridge_node:FoxgloveBridgeNode, "
            "ground_station.gcs_server_node:GroundStationServerNode)")


def _launch_faults(args: argparse.Namespace, description: Any) -> tuple[Any, list[Any]]:
    """The description with ``--fault``/``--faults`` handed to its simulator, and under
    ``ros2`` the (wall time, process) kills of the ``node_stop`` faults; a fault the launch cannot
    play is refused naming it."""
    import dataclasses
    import inspect

    from quadmission.errors import OptionsError
    from runtime.launch import _resolve
    from sim.fault_spec import FaultKind, load_faults, parse_faults

    faults = parse_faults(args.fault) + (load_faults(args.faults) if args.faults else ())
    if not faults:
        return description, []
    sim = description.simulator
    if sim is None:
        raise OptionsError("--fault: the launch file has no simulator to inject it into")
    if "faults" not in inspect.signature(_resolve(sim.factory, "simulator")).parameters:
        raise OptionsError(f"--fault: the simulator {sim.factory} takes no faults "
                           "(quadmission.scenarios.mission.launch:sitl does)")
    processes = args.transport == "ros2"  # a process transport: node_stop kills
    kills: list[tuple[float, str]] = []
    given: list[str] = []
    for f in faults:
        if f.kind is FaultKind.OPERATOR_ABORT or (processes
                                                  and f.kind is FaultKind.OPERATOR_SILENT):
            raise OptionsError(f"--fault {f.spec()}: not in a launch"
                               f"{' over ros2' if processes else ''}; quadmission sim "
                               "--scenario mission plays it")
        if processes and f.kind is FaultKind.NODE_STOP:
            if f.duration_s is not None:
                raise OptionsError(f"--fault {f.spec()}: over ros2 a killed process comes back "
                                   "by its launch file's respawn (respawn: true, "
                                   "respawn_delay: S), not a duration")
            name = f.text("name")
            named = {n.name: n.process_name() for n in description.nodes if n.name}
            groups = sorted({n.process_name() for n in description.nodes})
            process = named.get(name, name if name in groups else None)
            if process is None:
                raise OptionsError(f"--fault {f.spec()}: over ros2, name= a process of the "
                                   f"launch file ({', '.join(groups)}) or a node's name: in it "
                                   f"({', '.join(sorted(named)) or 'none'})")
            kills.append((f.at_s / (1.0 if args.rtf is None else args.rtf), process))
        else:
            given.append(f.spec())
    params = dict(sim.parameters) | {"faults": given}
    return dataclasses.replace(description, simulator=dataclasses.replace(
        sim, parameters=params)), kills


def _launch_processes(args: argparse.Namespace, description: Any,
                      kills: list[Any] | None = None) -> int:
    from ground_station.server import TOKEN_ENV
    from runtime.launch import LaunchDescription
    from runtime.processes.launcher import process_specs, run_launch

    services = _run_services(args)  # --record, --foxglove, --gcs: a process of their own
    if services.gcs is not None:
        os.environ[TOKEN_ENV] = services.gcs.token  # the page's process inherits it
    description = LaunchDescription((*description.nodes, *services.process_nodes(args.out)),
                                    description.simulator)
    specs = process_specs(
        description, transport=args.transport, domain_id=args.domain_id,
        loopback_only=not args.network, use_sim_time=not args.wall_clock,
        rtf=1.0 if args.rtf is None else args.rtf,
        duration_s=args.duration or SIMULATOR_TIME_LIMIT_S,
        config_dir=None if args.config_dir is None else str(args.config_dir.resolve()))
    result = run_launch(specs, kills=kills or ())
    print(f"launch: {result.reason}", file=sys.stderr)
    print(json.dumps({"exit_code": result.exit_code, "reason": result.reason}))
    return result.exit_code


def _launch_run(args: argparse.Namespace) -> int:
    from runtime import DeterministicExecutor, LaunchDescription, launch
    from runtime.launch import run_in_process

    description = LaunchDescription.from_yaml(args.file)
    _refuse_ignored_services(args, description.simulator is not None)
    description, kills = _launch_faults(args, description)
    if args.transport == "ros2":
        return _launch_processes(args, description, kills)
    ex = (DeterministicExecutor() if args.config_dir is None
          else DeterministicExecutor(config_dir=args.config_dir))
    if description.simulator is not None:
        with _run_services(args).attach(ex, [], args.out):
            outcome = run_in_process(description, ex, args.duration or SIMULATOR_TIME_LIMIT_S)
        print(f"launch: {outcome.reason} at {outcome.sim_time_s:.1f} s", file=sys.stderr)
        print(json.dumps({"exit_code": outcome.exit_code, "reason": outcome.reason,
                          "sim_time_s": outcome.sim_time_s}))
        return outcome.exit_code
    args.duration = args.duration or 10.0
    nodes = launch(description, ex)
    print(f"launched {len(nodes)} node(s): "
          + ", ".join(n.get_fully_qualified_name() for n in nodes), file=sys.stderr)
    services = _run_services(args)
    parts: list[Any] = []
    with services.attach(ex, parts, args.out):
        pacer = parts[0] if parts else None
        steps = max(1, int(args.duration))
        for _ in range(steps):
            _spin_paced(ex, args.duration / steps, pacer)
            print(f"  t={ex.now().seconds:.1f}s callbacks={ex.callbacks_run}", file=sys.stderr)
    print(json.dumps({"sim_time_s": ex.now().seconds, "callbacks": ex.callbacks_run}),
          flush=True)
    _linger(services, args)
    return 0


def _spin_paced(ex: Any, seconds: float, pacer: Any) -> None:
    """Spin ``seconds`` of executor time, in pacer-sized slices when pacing."""
    if pacer is None:
        ex.spin_for(seconds)
        return
    end = ex.now().nanoseconds + round(seconds * 1e9)
    slice_ns = round(1e9 / pacer.rate_hz)
    while ex.now().nanoseconds < end:
        ex.spin_until(min(end, ex.now().nanoseconds + slice_ns))
        pacer.update(ex.now().nanoseconds, None)


# -- sim -------------------------------------------------------------------------------------
def _sim_args(p: argparse.ArgumentParser) -> None:
    from quadmission.scenarios import DEFAULT_SCENARIO, SCENARIOS

    p.add_argument("--scenario", default=DEFAULT_SCENARIO, choices=sorted(SCENARIOS),
                   help=f"what to run (default: {DEFAULT_SCENARIO})")
    p.add_argument("--out", type=Path, default=Path("runs/default"),
                   help="folder for report.json, pictures and logs")
    _world_args(p)
    p.add_argument("--target-robot", type=int, default=None, metavar="ID",
                   help="mission: the robot marker to find (default: config/mission.yaml's)")
    p.add_argument("--remove-pad", type=int, default=None, metavar="ID",
                   help="mission: remove this pad from the field, which the mission still "
                        "believes is there (seed 003, 4.2: the pad-search branch)")
    _fault_args(p, "the kinds each scenario takes: docs/scenarios.md")
    _run_services_args(p)


def _world_args(p: argparse.ArgumentParser) -> None:
    """The world a run flies in: --seed, --arena or --random-arena, --lighting."""
    from sim.arena import Lighting

    p.add_argument("--seed", type=int, default=0, help="random seed (same seed, same run)")
    arena = p.add_mutually_exclusive_group()
    arena.add_argument("--arena", type=Path, default=None,
                       help="arena YAML (default config/arenas/contest.yaml)")
    arena.add_argument("--random-arena", action="store_true",
                       help="generate a random arena from --seed instead")
    p.add_argument("--lighting", choices=[preset.value for preset in Lighting], default=None,
                   help="lighting preset (default: the arena's own)")


def _fault_args(p: argparse.ArgumentParser, kinds: str) -> None:
    p.add_argument("--fault", action="append", default=[], metavar="SPEC",
                   help="inject a fault, KIND@T[:DURATION][,key=value...] in simulated "
                        f"seconds (repeatable; {kinds})")
    p.add_argument("--faults", type=Path, default=None, metavar="FILE.yaml",
                   help="inject the faults listed in this YAML file")


def _faults_of(args: argparse.Namespace) -> tuple[Any, ...]:
    """``--fault`` and ``--faults``; a bad spec is a SimError naming the bad part."""
    from sim.fault_spec import load_faults, parse_faults

    return tuple(parse_faults(args.fault)) + tuple(load_faults(args.faults)
                                                   if args.faults else ())


def _stderr(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def _sim_run(args: argparse.Namespace) -> int:
    from quadmission.assembly.faults import check_faults
    from quadmission.errors import ScenarioRefused
    from quadmission.reports.report import REPORT_NAME
    from quadmission.scenarios import SCENARIOS, ScenarioOptions
    from sim.arena import Lighting

    # a bad spec is a SimError: one line naming the bad part, exit code 2
    faults = _faults_of(args)
    check_faults(args.scenario, faults)  # the kinds this scenario takes, or why not
    services = _run_services(args)
    options = ScenarioOptions(out=args.out, seed=args.seed, arena=args.arena,
                              faults=faults,
                              random_arena=args.random_arena,
                              lighting=Lighting(args.lighting) if args.lighting else None,
                              target_robot=args.target_robot, remove_pad=args.remove_pad,
                              progress=_stderr, services=services)
    arena = "random" if args.random_arena else (args.arena or "default")
    _stderr(f"quadmission sim: scenario {args.scenario}, arena {arena}, seed {args.seed}, "
            f"out {args.out}")
    try:
        report = SCENARIOS[args.scenario](options)
    except ScenarioRefused as exc:
        _stderr(f"REFUSED: {exc}")
        services.close()
        return 2
    print(json.dumps({k: v for k, v in report.items() if not isinstance(v, list | dict)},
                     allow_nan=False), flush=True)
    _stderr(f"report: {args.out / REPORT_NAME}")
    _stderr(str(report.get("verdict", "")))
    _linger(services, args)
    return 0 if report.get("ok", report.get("all_decoded", True)) else 1


def _run_services_args(p: argparse.ArgumentParser) -> None:
    """Options every run shares: pacing, recording, Foxglove, the operator page."""
    p.add_argument("--rtf", type=_positive_float, default=None,
                   help="pace the run to this many times real time (default: as fast as it "
                        "goes; --gcs implies 1)")
    p.add_argument("--record", action="store_true",
                   help="record the topics to a rosbag2 MCAP in OUT/bag (crash-safe)")
    p.add_argument("--foxglove", action="store_true",
                   help="serve the live topics to Foxglove (ws://127.0.0.1:8765)")
    p.add_argument("--foxglove-port", type=int, default=8765, help="Foxglove bridge port")
    p.add_argument("--gcs", action="store_true",
                   help="serve the operator page (http://127.0.0.1:8080) during the run")
    p.add_argument("--host", default=None,
                   help="address the page and the Foxglove bridge bind to (default loopback)")
    p.add_argument("--port", type=int, default=None,
                   help="operator page port (default config/ground_station.yaml's 8080; 0: any)")
    p.add_argument("--gcs-linger", action="store_true",
                   help="with --gcs: keep the page up after the run until Ctrl-C")


def _run_services(args: argparse.Namespace) -> Any:
    from ground_station.server import resolve_token
    from quadmission.assembly.services import GcsOptions, RunServices

    gcs = GcsOptions(args.host, args.port, resolve_token()) if args.gcs else None
    return RunServices(rtf=args.rtf, record=args.record, foxglove=args.foxglove,
                       foxglove_host=args.host or "127.0.0.1", foxglove_port=args.foxglove_port,
                       gcs=gcs,
                       origin_host_s=_STARTED_HOST_S, say=_stderr)


def _linger(services: Any, args: argparse.Namespace) -> None:
    try:
        if services.server is not None and args.gcs_linger:
            _stderr(f"run over; the page stays at {services.server.url} until Ctrl-C")
            while True:
                time.sleep(1.0)
    finally:
        services.close()


# -- vehicle ---------------------------------------------------------------------------------
def _vehicle_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--out", type=Path, default=Path("runs/vehicle"),
                   help="folder for the ground truth: truth.npz (the true trajectory), "
                        "vehicle.json (touchdowns, the FCU's failsafes, a crash, how far "
                        "it fell behind real time), arena.yaml; written when it ends")
    _world_args(p)
    _fault_args(p, "the simulator's kinds: docs/scenarios.md")
    p.add_argument("--rtf", type=_positive_float, default=1.0,
                   help="pace to this many times real time (default 1; a companion on the "
                        "host's clock flies it at 1 only)")
    p.add_argument("--domain-id", type=int, default=0, help="the DDS domain id (ROS_DOMAIN_ID)")
    p.add_argument("--network", action="store_true",
                   help="discover and talk beyond this machine (default: localhost only)")
    p.add_argument("--duration", type=_positive_seconds, default=None,
                   help="stop after this many simulated seconds (default: a day; SIGINT "
                        "or SIGTERM stops it, writing what it has)")
    p.add_argument("--config-dir", type=Path, default=None,
                   help="simulator YAMLs (default: config/)")


def _vehicle_options(args: argparse.Namespace, out: Path) -> Any:
    """The vehicle's options from the arguments ``vehicle`` and ``fly-realtime`` share
    (a bad one is said here, before anything starts)."""
    from quadmission.vehicle.run import VehicleOptions
    from sim.arena import Lighting

    return VehicleOptions(
        out=out, seed=args.seed, arena=args.arena, random_arena=args.random_arena,
        lighting=Lighting(args.lighting) if args.lighting else None,
        faults=_faults_of(args), rtf=getattr(args, "rtf", 1.0), domain_id=args.domain_id,
        loopback_only=not getattr(args, "network", False),
        **({} if getattr(args, "duration", None) is None else {"duration_s": args.duration}),
        config_dir=None if getattr(args, "config_dir", None) is None
        else args.config_dir.resolve())


def _vehicle_run(args: argparse.Namespace) -> int:
    from quadmission.vehicle.run import run_vehicle

    outcome = run_vehicle(_vehicle_options(args, args.out),
                          lambda line: _stderr(f"[vehicle] {line}"))
    print(json.dumps({"exit_code": outcome.exit_code, "reason": outcome.reason,
                      "out": str(args.out)}), flush=True)
    return outcome.exit_code


# -- fly-realtime ----------------------------------------------------------------------------
#: fly-realtime's ROS domain: not 0, where a launch or a user's stack runs by default
REALTIME_DOMAIN_ID = 38


def _fly_realtime_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--out", type=Path, default=Path("runs/realtime"),
                   help="folder for report.json, mission.json, the logs and the vehicle's "
                        "ground truth (OUT/vehicle)")
    _world_args(p)
    _fault_args(p, "the vehicle's: the simulator's kinds")
    p.add_argument("--domain-id", type=int, default=REALTIME_DOMAIN_ID,
                   help=f"the run's own ROS domain (default {REALTIME_DOMAIN_ID})")
    p.add_argument("--until-state", default=None, metavar="STATE",
                   help="end once the mission enters STATE (e.g. mission.pad.takeoff: "
                        "after the first pad's landing)")
    p.add_argument("--timeout", type=_positive_seconds, default=1800.0,
                   help="host seconds the companion may fly at most (default 1800)")


def _fly_realtime_run(args: argparse.Namespace) -> int:
    from quadmission.scenarios.mission.realtime import RealtimeOptions, fly_realtime

    report = fly_realtime(RealtimeOptions(
        out=args.out, vehicle=_vehicle_options(args, args.out / "vehicle"),
        until_state=args.until_state, timeout_s=args.timeout, say=_stderr))
    print(json.dumps({k: v for k, v in report.items() if not isinstance(v, list | dict)},
                     allow_nan=False), flush=True)
    _stderr(f"report: {args.out / 'report.json'}")
    _stderr(str(report["verdict"]))
    reached = args.until_state is not None and report["companion_exit_code"] == 0
    return 0 if report["ok"] or reached else 1


# -- campaign --------------------------------------------------------------------------------
def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text} must be at least 1")
    return value


def _campaign_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", type=Path, help="campaign YAML: a matrix of scenarios x seeds x "
                   "lighting x faults (docs/campaigns.md), e.g. config/campaigns/faults.yaml")
    p.add_argument("--out", type=Path, required=True,
                   help="folder for results.parquet, summary.md, the plots, and each run "
                        "in OUT/runs/; run again into the same folder to resume")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=_positive_int, default=None, metavar="N",
                       help="worker processes of the local Dask cluster (default: one a core)")
    where.add_argument("--scheduler", default=None, metavar="ADDR",
                       help="run on an existing Dask cluster, e.g. tcp://10.0.0.5:8786")
    p.add_argument("--limit", type=_positive_int, default=None, metavar="N",
                   help="run only the campaign's first N runs (a quick look)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")


def _campaign_run(args: argparse.Namespace) -> int:
    from quadmission.campaigns.matrix import load_campaign
    from quadmission.campaigns.results import RESULTS_NAME
    from quadmission.campaigns.runner import SUMMARY_NAME, run_campaign

    campaign = load_campaign(args.file).limited(args.limit)
    # SIGTERM, and SIGINT even where a shell started the campaign in the background with it
    # ignored (`... &`), stop it as Ctrl-C does: the finished runs' results are written
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, signal.default_int_handler)
    result = run_campaign(campaign, args.out, source=str(args.file), workers=args.workers,
                          scheduler=args.scheduler, progress=not args.no_progress,
                          say=_stderr)
    s = result.summary
    print(json.dumps({"runs": len(campaign.cells), "finished": s.runs, "passed": s.passed,
                      "failed": len(s.failed), "not_finished": result.session.lost,
                      "requeued": s.requeued, "results": str(result.out / RESULTS_NAME),
                      "summary": str(result.out / SUMMARY_NAME)}), flush=True)
    _stderr(f"summary: {result.out / SUMMARY_NAME}")
    return 0 if s.passed == len(campaign.cells) else 1


# -- fcu-schedule ----------------------------------------------------------------------------
def _fcu_schedule_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--offsets", default="balanced", choices=("balanced", "naive"),
                   help="offset strategy for the periodic functions")
    p.add_argument("--flight-s", type=_positive_seconds, default=10.0,
                   help="simulated seconds of hover to measure duty and rates")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--json", action="store_true", help="print the report as JSON")


def _fcu_schedule_run(args: argparse.Namespace) -> int:
    from quadmission.assembly.offboard_harness import hover_flight
    from sim.fcu.sitl import schedule_report

    print(f"flying {args.flight_s:.0f} s of hover to measure the schedule...", file=sys.stderr)
    sitl, _ = hover_flight(args.flight_s, seed=args.seed, offsets=args.offsets)
    report = schedule_report(sitl)
    if args.json:
        print(json.dumps(report, indent=2))
        return 0
    print(f"main loop {report['main_freq_hz']} Hz, offsets {report['offsets']}, "
          f"functions per tick: peak {report['functions_per_tick']['peak']}, "
          f"mean {report['functions_per_tick']['mean']}")
    print("module order: " + " -> ".join(report["module_order"]))
    print(f"\n{'group':<12}{'module':<20}{'function':<28}{'Hz':>7}{'presc':>7}{'offset':>7}"
          f"{'achieved':>10}")
    for p in report["periodics"]:
        print(f"{p['group']:<12}{p['module']:<20}{p['function']:<28}{p['freq_hz']:>7g}"
              f"{p['prescaler']:>7}{p['offset']:>7}{p['achieved_hz']:>10.2f}")
    print(f"\n{'task group':<14}{'duty avg us':>12}{'min':>9}{'max':>9}{'Hz':>9}")
    for g in report["groups"]:
        print(f"{g['group']:<14}{g['duty_avg_us']:>12.1f}{g['duty_min_us']:>9.1f}"
              f"{g['duty_max_us']:>9.1f}{g['freq_hz']:>9.2f}")
    print(f"\ntick duty avg {report['tick_duty_avg_us']} us, max {report['tick_duty_max_us']} us"
          f" over {report['ticks']} ticks; overruns {report['overruns']} (host time vs the "
          f"{1e6 / report['main_freq_hz']:.0f} us period)")
    return 0


# -- latency -------------------------------------------------------------------------------
def _latency_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--duration", type=_positive_seconds, default=60.0,
                   help="simulated seconds to run")
    p.add_argument("--seed", type=int, default=0, help="random seed (same seed, same run)")
    p.add_argument("--estimator", default="kalman", choices=("kalman", "px4"),
                   help="time-sync estimator of the top-level JSON figures (both always run)")
    p.add_argument("--json", action="store_true", help="print the report as JSON")
    p.add_argument("--fit", action="store_true",
                   help="instead, refit the link's jitter so that the test reproduces Table 3 "
                        "(seeds SEED..SEED+2, --duration each; two refits, 9 runs; slow) "
                        "and print the values for config/fcu_link.yaml")


def _latency_run(args: argparse.Namespace) -> int:
    from quadmission.experiments.latency import (
        LatencyConfig,
        fit_link,
        format_fit,
        format_report,
        run_latency_experiment,
    )

    config = LatencyConfig(duration_s=args.duration, seed=args.seed, primary=args.estimator)
    if args.fit:
        seeds = tuple(range(args.seed, args.seed + 3))
        print(f"fitting the link: seeds {seeds}, {args.duration:g} s simulated each, "
              f"9 runs...", file=sys.stderr)
        print(format_fit(fit_link(seeds=seeds, duration_s=args.duration), seeds,
                         args.duration))
        return 0
    print(f"running the latency test for {args.duration:g} s simulated...", file=sys.stderr)
    report = run_latency_experiment(config)
    print(json.dumps(report.to_json(), indent=2) if args.json else format_report(report))
    return 0


# -- bag -----------------------------------------------------------------------------------
def _bag_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("action", choices=("info", "repair"),
                   help="info: topics, counts, duration; repair: re-index a killed recording")
    p.add_argument("bag", type=Path, help="a bag folder (OUT/bag) or its .mcap file")
    p.add_argument("--json", action="store_true", help="print the result as JSON")


def _bag_run(args: argparse.Namespace) -> int:
    from ground_station.bag import bag_info, repair_bag

    if args.action == "repair":
        result = repair_bag(args.bag)
        if args.json:
            print(json.dumps(result.to_json(), indent=2))
        elif result.repaired:
            print(f"repaired {result.path}: {result.messages} messages on {result.topics} "
                  f"topics kept, {result.bytes_dropped} bytes of cut tail dropped")
        else:
            print(f"{result.path} is already indexed ({result.messages} messages); unchanged")
        return 0
    info = bag_info(args.bag)
    if args.json:
        print(json.dumps(info.to_json(), indent=2))
        return 0
    state = "indexed" if info.indexed else "NOT indexed (killed?): run quadmission bag repair"
    print(f"{info.path}: {state}")
    print(f"duration {info.duration_s:.3f} s, {info.message_count} messages, "
          f"{len(info.topics)} topics")
    width = max((len(t.name) for t in info.topics), default=0)
    for t in info.topics:
        print(f"  {t.name:<{width}}  {t.count:>8}  {t.msgtype}")
    return 0


# -- gcs -------------------------------------------------------------------------------------
def _gcs_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--replay", type=Path, required=True,
                   help="a recorded bag (OUT/bag) to play into the page")
    p.add_argument("--arena", type=Path, default=None,
                   help="arena YAML for the map (default: the run's arena.yaml beside the bag)")
    p.add_argument("--rtf", type=_positive_float, default=1.0,
                   help="playback speed, times real time")
    p.add_argument("--host", default=None,
                   help="address the page binds to (default loopback)")
    p.add_argument("--port", type=int, default=None, help="page port (default 8080; 0: any)")
    p.add_argument("--foxglove", action="store_true",
                   help="also serve the replayed topics to Foxglove")
    p.add_argument("--foxglove-port", type=int, default=8765)


def _gcs_run(args: argparse.Namespace) -> int:
    from ground_station.player import BagPlayer
    from quadmission.assembly.pacing import RealTimePacer
    from quadmission.assembly.services import GcsOptions, RunServices
    from runtime import DeterministicExecutor
    from sim.arena import load_arena

    arena_file = args.arena or next(
        (p / "arena.yaml" for p in (args.replay, args.replay.parent, args.replay.parent.parent)
         if (p / "arena.yaml").is_file()), None)
    arena = load_arena(arena_file) if arena_file else None
    from ground_station.server import resolve_token

    services = RunServices(rtf=args.rtf, foxglove=args.foxglove,
                           foxglove_host=args.host or "127.0.0.1",
                           foxglove_port=args.foxglove_port,
                           gcs=GcsOptions(args.host, args.port, resolve_token()), say=_stderr)
    ex = DeterministicExecutor()
    player = BagPlayer(args.replay, ex)
    parts: list[Any] = []
    try:
        with services.attach(ex, parts, args.replay.parent, arena):
            _stderr(f"replaying {player.path} at {args.rtf:g}x; Ctrl-C stops")
            pacer = RealTimePacer(args.rtf)
            while (offset := player.next_offset_ns()) is not None:
                pacer.pace(offset)
                player.step()
            _stderr(f"replayed {player.played} messages; the page stays up until Ctrl-C")
            while True:
                time.sleep(1.0)
    finally:
        player.close()
        services.close()


# -- fsm -------------------------------------------------------------------------------------
def _fsm_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--diagram", action="store_true",
                   help="the README block: a mermaid state diagram and the error policy")


def _fsm_run(args: argparse.Namespace) -> int:
    from fsm.diagram import readme_block, transition_table

    print(readme_block() if args.diagram else transition_table(), end="")
    return 0


COMMANDS: tuple[Command, ...] = (
    Command("sim", "run a scenario in the MuJoCo arena and write a report", _sim_args, _sim_run),
    Command("campaign", "run a matrix of scenarios x seeds x faults x lighting on Dask",
            _campaign_args, _campaign_run),
    Command("fcu-schedule", "the flight controller's resolved schedule and measured duty",
            _fcu_schedule_args, _fcu_schedule_run),
    Command("latency", "seed 000's FCU <-> companion latency test (Table 3), with time sync",
            _latency_args, _latency_run),
    Command("fsm", "the mission state machine's transitions (--diagram: mermaid, for the README)",
            _fsm_args, _fsm_run),
    Command("launch", "run a launch file's nodes in simulated time", _launch_args, _launch_run),
    Command("vehicle", "the simulated vehicle alone on the wall clock, where PX4 v1.17, its "
            "uXRCE-DDS agent, the cameras and a VIO stand (ROS 2)", _vehicle_args,
            _vehicle_run),
    Command("fly-realtime", "the mission in real time: the vehicle, companion.yaml and an "
            "operator in processes, scored against the vehicle's truth", _fly_realtime_args,
            _fly_realtime_run),
    Command("interfaces", "list message types, or show one: field types and defaults",
            _interfaces_args, _interfaces_run),
    Command("bag", "a recorded rosbag2 MCAP: info (topics, counts, duration) or repair",
            _bag_args, _bag_run),
    Command("gcs", "the operator page over a recorded run (live runs: sim --gcs)",
            _gcs_args, _gcs_run),
)


def build_parser(commands: Sequence[Command] = COMMANDS) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="quadmission",
        description="Autonomous quadcopter mission stack: simulation, nodes, tools.",
        epilog=EXIT_CODES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("-v", "--verbose", action="store_true", help="debug logging")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for command in commands:
        p = sub.add_parser(command.name, help=command.help, description=command.help,
                           epilog=EXIT_CODES, formatter_class=argparse.RawDescriptionHelpFormatter)
        command.add_arguments(p)
        p.set_defaults(handler=command.run)
    return parser


def _quiet_stdout() -> None:
    """Point stdout at /dev/null, so that the interpreter's last flush cannot fail again."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())


def main(argv: Sequence[str] | None = None, commands: Sequence[Command] = COMMANDS) -> int:
    """Run one subcommand; the exit code is one of :data:`EXIT_CODES`."""
    # headless by default: mujoco reads this when it is first imported
    os.environ.setdefault("MUJOCO_GL", "egl")
    args = build_parser(commands).parse_args(argv)
    logging.basicConfig(level=logging.DEBUG if args.verbose else logging.INFO,
                        format="%(levelname)s %(name)s: %(message)s")
    if not args.verbose:  # the state machine library narrates every callback at INFO,
        logging.getLogger("transitions").setLevel(logging.WARNING)
        # and Dask each connection (read when distributed is imported, workers included)
        os.environ.setdefault("DASK_LOGGING__DISTRIBUTED", "warning")
    try:
        code = int(args.handler(args))
        sys.stdout.flush()  # a closed pipe shows here, not at exit
        return code
    except BrokenPipeError:
        _quiet_stdout()
        return EXIT_BROKEN_PIPE
    except KeyboardInterrupt:
        print(f"quadmission {args.command}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Exception as exc:
        if args.verbose or not isinstance(exc, project_errors()):
            raise  # a bug (or -v): the traceback is what a report needs
        print(f"quadmission {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT


if __name__ == "__main__":
    sys.exit(main())
