"""The ``quadmission`` command: one entry point, one subcommand per capability."""

from __future__ import annotations

import argparse
import json
import logging
import os
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

Handler = Callable[[argparse.Namespace], int]


@dataclass(frozen=True)
class Command:
    """A subcommand: its name, one line of help, its arguments and what it runs."""

    name: str
    help: str
    add_arguments: Callable[[argparse.ArgumentParser], None]
    run: Handler


# -- interfaces ------------------------------------------------------------------------------
def _interfaces_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("name", nargs="?", help="a type to show, e.g. px4_msgs/msg/VehicleOdometry")
    p.add_argument("--package", help="list only this package's types")


def _interfaces_run(args: argparse.Namespace) -> int:
    import interfaces

    if args.name:
        msg = interfaces.new(args.name)
        consts, fields = interfaces.typestore().fielddefs[interfaces.type_name(msg)]
        for cname, ctype, value in consts:
            print(f"{ctype} {cname}={value}")
        for fname, _node in fields:
            print(f"{fname}: {getattr(msg, fname)!r}")
        return 0
    for name in interfaces.registered_types(args.package):
        print(name)
    return 0


# -- launch ----------------------------------------------------------------------------------
def _launch_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", type=Path, help="launch YAML: nodes: [{factory, name, ...}]")
    p.add_argument("--duration", type=float, default=10.0, help="simulated seconds to run")
    p.add_argument("--config-dir", type=Path, default=None, help="node YAMLs (default config/)")


def _launch_run(args: argparse.Namespace) -> int:
    from runtime import DeterministicExecutor, LaunchDescription, launch
    from runtime.executor import DEFAULT_CONFIG_DIR

    if args.duration <= 0:
        raise ValueError(f"--duration must be positive, got {args.duration}")
    ex = DeterministicExecutor(config_dir=args.config_dir or DEFAULT_CONFIG_DIR)
    nodes = launch(LaunchDescription.from_yaml(args.file), ex)
    print(f"launched {len(nodes)} node(s): "
          + ", ".join(n.get_fully_qualified_name() for n in nodes), file=sys.stderr)
    steps = max(1, int(args.duration))
    for _ in range(steps):
        ex.spin_for(args.duration / steps)
        print(f"  t={ex.now().seconds:.1f}s callbacks={ex.callbacks_run}", file=sys.stderr)
    print(json.dumps({"sim_time_s": ex.now().seconds, "callbacks": ex.callbacks_run}))
    return 0


# -- sim -------------------------------------------------------------------------------------
def _sim_args(p: argparse.ArgumentParser) -> None:
    from quadmission.scenarios import DEFAULT_SCENARIO, SCENARIOS

    p.add_argument("--scenario", default=DEFAULT_SCENARIO, choices=sorted(SCENARIOS),
                   help=f"what to run (default: {DEFAULT_SCENARIO})")
    p.add_argument("--out", type=Path, default=Path("runs/default"),
                   help="folder for report.json, pictures and logs")
    p.add_argument("--seed", type=int, default=0, help="random seed (same seed, same run)")
    arena = p.add_mutually_exclusive_group()
    arena.add_argument("--arena", type=Path, default=None,
                       help="arena YAML (default config/arenas/contest.yaml)")
    arena.add_argument("--random-arena", action="store_true",
                       help="generate a random arena from --seed instead")


def _stderr(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def _sim_run(args: argparse.Namespace) -> int:
    from quadmission.errors import ScenarioRefused
    from quadmission.report import REPORT_NAME
    from quadmission.scenarios import SCENARIOS, ScenarioOptions

    options = ScenarioOptions(out=args.out, seed=args.seed, arena=args.arena,
                              random_arena=args.random_arena, progress=_stderr)
    arena = "random" if args.random_arena else (args.arena or "default")
    _stderr(f"quadmission sim: scenario {args.scenario}, arena {arena}, seed {args.seed}, "
            f"out {args.out}")
    try:
        report = SCENARIOS[args.scenario](options)
    except ScenarioRefused as exc:
        _stderr(f"REFUSED: {exc}")
        return 2
    print(json.dumps({k: v for k, v in report.items() if not isinstance(v, list | dict)},
                     allow_nan=False))
    _stderr(f"report: {args.out / REPORT_NAME}")
    _stderr(str(report.get("verdict", "")))
    return 0 if report.get("ok", report.get("all_decoded", True)) else 1


# -- fcu-schedule ----------------------------------------------------------------------------
def _fcu_schedule_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--offsets", default="balanced", choices=("balanced", "naive"),
                   help="offset strategy for the periodic functions")
    p.add_argument("--flight-s", type=float, default=10.0,
                   help="simulated seconds of hover to measure duty and rates")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--json", action="store_true", help="print the report as JSON")


def _fcu_schedule_run(args: argparse.Namespace) -> int:
    from quadmission.offboard_harness import hover_flight
    from sim.fcu.sitl import schedule_report

    if args.flight_s <= 0:
        raise ValueError(f"--flight-s must be positive, got {args.flight_s}")
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
    p.add_argument("--duration", type=float, default=60.0, help="simulated seconds to run")
    p.add_argument("--seed", type=int, default=0, help="random seed (same seed, same run)")
    p.add_argument("--estimator", default="kalman", choices=("kalman", "px4"),
                   help="time-sync estimator of the top-level JSON figures (both always run)")
    p.add_argument("--json", action="store_true", help="print the report as JSON")


def _latency_run(args: argparse.Namespace) -> int:
    from quadmission.latency import LatencyConfig, format_report, run_latency_experiment

    config = LatencyConfig(duration_s=args.duration, seed=args.seed, primary=args.estimator)
    print(f"running the latency test for {args.duration:g} s simulated...", file=sys.stderr)
    report = run_latency_experiment(config)
    print(json.dumps(report.to_json(), indent=2) if args.json else format_report(report))
    return 0


COMMANDS: tuple[Command, ...] = (
    Command("sim", "run a scenario in the MuJoCo arena and write a report", _sim_args, _sim_run),
    Command("fcu-schedule", "the flight controller's resolved schedule and measured duty",
            _fcu_schedule_args, _fcu_schedule_run),
    Command("latency", "seed 000's FCU <-> companion latency test (Table 3), with time sync",
            _latency_args, _latency_run),
    Command("launch", "run a launch file's nodes in simulated time", _launch_args, _launch_run),
    Command("interfaces", "list message types, or show one with its defaults",
            _interfaces_args, _interfaces_run),
)


def build_parser(commands: Sequence[Command] = COMMANDS) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="quadmission",
        description="Autonomous quadcopter mission stack: simulation, nodes, tools.",
    )
    parser.add_argument("-v", "--verbose", action="store_true", help="debug logging")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for command in commands:
        p = sub.add_parser(command.name, help=command.help, description=command.help)
        command.add_arguments(p)
        p.set_defaults(handler=command.run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    # headless by default: mujoco reads this when it is first imported
    os.environ.setdefault("MUJOCO_GL", "egl")
    args = build_parser().parse_args(argv)
    logging.basicConfig(level=logging.DEBUG if args.verbose else logging.INFO,
                        format="%(levelname)s %(name)s: %(message)s")
    try:
        return int(args.handler(args))
    except Exception as exc:  # a user-facing tool: say what was wrong, no traceback
        if args.verbose:
            raise
        print(f"quadmission {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
