"""Simulated flight controller cost: real-time factor and Python cost of a main-loop tick.

    python benchmarks/bench_fcu.py --out benchmarks/results/fcu.json

Measured side by side in one run:
- real-time factor of a software-in-the-loop hover (firmware at 500 Hz behind the serial
  link, offboard harness, vision at 30 Hz, no camera) against the bare world loop
  flying the same vehicle on constant hover thrust (no firmware): the ratio is what the
  flight controller costs;
- host time of one firmware main-loop tick (mean and max of the scheduler's duty
  measurement) against the main-loop period it must fit in (2000 us at 500 Hz), for
  both offset strategies.
"""

from __future__ import annotations

import os
from typing import Any

os.environ.setdefault("MUJOCO_GL", "egl")

from _harness import bench_parser, write_result

from quadmission.assembly.offboard_harness import hover_flight
from runtime import DeterministicExecutor
from sim.arena import default_arena
from sim.fcu.sitl import schedule_report
from sim.quadrotor import MotorModel
from sim.world import Actuation, ConstantThrust, RobotMotion, Scene, run_world


def bench(seconds: float) -> dict[str, Any]:
    out: dict[str, Any] = {"sim_seconds": seconds}
    hover_flight(1.0)  # warm up: message code generation, GL-free imports
    for offsets in ("balanced", "naive"):
        sitl, result = hover_flight(seconds, offsets=offsets)
        report = schedule_report(sitl)
        out[offsets] = {
            "rtf_sitl": round(result.real_time_factor, 2),
            "tick_mean_us": report["tick_duty_avg_us"],
            "tick_max_us": report["tick_duty_max_us"],
            "tick_budget_us": 1e6 / report["main_freq_hz"],
            "tick_mean_over_budget": round(report["tick_duty_avg_us"] * report["main_freq_hz"]
                                           / 1e6, 3),
            "overruns": report["overruns"],
            "functions_per_tick_peak": report["functions_per_tick"]["peak"],
        }
    scene = Scene.build(default_arena())
    scene.place_at_takeoff(height=1.0)
    bare = run_world(scene, DeterministicExecutor(config_dir=None),
                     duration_s=result.sim_time_s,
                     parts=[Actuation(ConstantThrust.hover(scene.quad),
                                      MotorModel.hovering(scene.quad)), RobotMotion()])
    out["rtf_bare_world"] = round(bare.real_time_factor, 2)
    out["ratio_sitl_over_bare"] = round(out["balanced"]["rtf_sitl"] / bare.real_time_factor, 3)
    return out


def main(argv: list[str] | None = None) -> int:
    parser = bench_parser(__doc__, "fcu")
    parser.add_argument("--seconds", type=float, default=20.0, help="simulated hover seconds")
    args = parser.parse_args(argv)
    report = bench(args.seconds)
    print(write_result(args.out, report), end="")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
