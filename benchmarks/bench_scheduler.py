"""Naive (seed 002) vs balanced offsets on a PX4-like module set.

Static figures: peak and mean periodic functions per main-loop tick over one hyperperiod,
and the same in estimated cost (us). Runtime figures: the scheduler runs the set with
every function bound to a host busy-wait of its declared cost, and reports duty per task
group (average, min, max per 1000 calls, us of host time), achieved frequencies in
simulated time and overruns, as in the seed's Table 2 and Figures 6-9. A second, heavy
scenario scales every cost so that the naive peak tick exceeds the 2 ms period.

    python benchmarks/bench_scheduler.py --out benchmarks/results/scheduler.json
"""

from __future__ import annotations

import dataclasses
import gc
import statistics
import time
from collections.abc import Callable
from typing import Any

from _harness import REQUIRED, bench_parser, host, load_1min, write_result

from sim.fcu import (
    ModuleSpec,
    PeriodicSpec,
    ResolvedSchedule,
    Scheduler,
    TaskGroup,
    call_pattern,
    resolve,
)
from sim.fcu.scheduler import DutyStats

G = TaskGroup
MAIN_FREQ_HZ = 500


def px4_like_modules(cost_scale: float = 1.0) -> list[ModuleSpec]:
    """A PX4-like firmware: rates in Hz, costs in us of host time (rough Python figures)."""

    def p(fun: str, freq_hz: float, cost_us: float) -> PeriodicSpec:
        return PeriodicSpec(fun, freq_hz=freq_hz, cost=cost_us * cost_scale)

    return [
        ModuleSpec("battery", G.CORE, provides=("battery",), periodics=(p("battery", 10, 5),)),
        ModuleSpec("imu", G.SENSORS, provides=("imu",), periodics=(p("imu_read", 500, 20),)),
        ModuleSpec("mag", G.SENSORS, provides=("mag",), periodics=(p("mag_read", 100, 10),)),
        ModuleSpec("baro", G.SENSORS, provides=("baro",), periodics=(p("baro_read", 50, 10),)),
        ModuleSpec("gps", G.SENSORS, provides=("gps",), periodics=(p("gps_read", 10, 10),)),
        ModuleSpec(
            "ekf2",
            G.ESTIMATION,
            depends=("@imu", "@mag", "@baro", "@gps"),
            provides=("ins",),
            periodics=(
                p("ekf_predict", 250, 80),
                p("ekf_fuse_mag", 100, 20),
                p("ekf_fuse_baro", 50, 20),
                p("ekf_fuse_gps", 10, 30),
            ),
        ),
        ModuleSpec("rc", G.RADIO_CONTROL, periodics=(p("rc_read", 50, 5),)),
        ModuleSpec("rate_ctrl", G.CONTROL, depends=("@ins",), periodics=(p("rate_ctrl", 500, 20),)),
        ModuleSpec(
            "att_ctrl",
            G.CONTROL,
            depends=("@ins", "rate_ctrl"),
            periodics=(p("att_ctrl", 250, 30),),
        ),
        ModuleSpec(
            "pos_ctrl", G.CONTROL, depends=("att_ctrl",), periodics=(p("pos_ctrl", 50, 40),)
        ),
        ModuleSpec("navigator", G.CONTROL, depends=("pos_ctrl",), periodics=(p("nav", 10, 40),)),
        ModuleSpec("mixer", G.ACTUATORS, depends=("rate_ctrl",), periodics=(p("mixer", 500, 10),)),
        ModuleSpec("mavlink_rx", G.DATALINK, periodics=(p("mavlink_rx", 100, 10),)),
        ModuleSpec(
            "mavlink_tx",
            G.TELEMETRY,
            depends=("@ins", "@battery"),
            periodics=(
                p("tlm_attitude", 100, 15),
                p("tlm_local_position", 50, 15),
                p("tlm_gps_raw", 10, 15),
                p("tlm_sys_status", 5, 15),
                p("tlm_heartbeat", 1, 15),
            ),
        ),
        ModuleSpec("logger", G.DEFAULT, periodics=(p("logger", 100, 25),)),
    ]


def _unit_costs(modules: list[ModuleSpec]) -> list[ModuleSpec]:
    return [
        dataclasses.replace(
            m, periodics=tuple(dataclasses.replace(s, cost=1.0) for s in m.periodics)
        )
        for m in modules
    ]


def _burner(cost_us: float) -> Callable[[], None]:
    """A function that busy-waits ``cost_us`` of host time."""
    cost_ns = int(cost_us * 1000)

    def burn() -> None:
        end = time.perf_counter_ns() + cost_ns
        while time.perf_counter_ns() < end:
            pass

    return burn


def _static(schedule: ResolvedSchedule) -> dict[str, Any]:
    pattern = call_pattern(schedule)
    cost = {p.fun: p.cost for p in schedule.periodics}
    period_us = 1e6 / schedule.main_freq_hz
    tick_costs = [sum(cost[f] for f in tick) for tick in pattern.ticks]
    return {
        "hyperperiod_ticks": pattern.hyperperiod_ticks,
        "peak_functions_per_tick": pattern.peak,
        "mean_functions_per_tick": round(pattern.mean, 4),
        "peak_cost_us_per_tick": round(pattern.peak_cost, 3),
        "mean_cost_us_per_tick": round(pattern.mean_cost, 3),
        "predicted_overrun_ticks_per_hyperperiod": sum(c > period_us for c in tick_costs),
        "offsets": {p.fun: [p.prescaler, p.offset] for p in schedule.periodics},
    }


def _duty(stats: DutyStats) -> dict[str, Any]:
    return {
        "calls": stats.calls,
        "avg_us": round(stats.avg_us, 3),
        "min_us": round(stats.min_us, 3),
        "max_us": round(stats.max_us, 3),
        "windows": [
            {
                "avg_us": round(w.avg_us, 3),
                "min_us": round(w.min_us, 3),
                "max_us": round(w.max_us, 3),
            }
            for w in stats.windows
        ],
    }


def _run(schedule: ResolvedSchedule, ticks: int) -> dict[str, Any]:
    costs = {p.fun: p.cost for p in schedule.periodics}
    scheduler = Scheduler(schedule, {fun: _burner(c) for fun, c in costs.items()})
    scheduler.init()
    gc.disable()  # keep collector pauses out of the duty figures
    try:
        wall_start = time.perf_counter()
        for _ in range(ticks):
            scheduler.tick()
        wall_s = time.perf_counter() - wall_start
    finally:
        gc.enable()
    report = scheduler.report()
    return {
        "ticks": report.ticks,
        "overruns": report.overruns,
        "wall_s": round(wall_s, 3),
        "tick": _duty(report.tick_duty),
        "groups": {
            g.value: {
                "duty": _duty(report.group_duty[g]),
                "freq_hz": round(report.group_freq[g].freq_hz, 3),
            }
            for g in report.group_duty
        },
        "functions_freq_hz": {fun: round(f.freq_hz, 3) for fun, f in report.function_freq.items()},
    }


def _runtime(schedules: dict[str, ResolvedSchedule], ticks: int, repeats: int) -> dict[str, Any]:
    """Runs alternate between strategies so that both see the same host load."""
    runs: dict[str, list[dict[str, Any]]] = {name: [] for name in schedules}
    for _ in range(repeats):
        for name, schedule in schedules.items():
            runs[name].append(_run(schedule, ticks))
    return {
        name: {
            "median_overruns": statistics.median(r["overruns"] for r in rs),
            "median_tick_max_us": statistics.median(r["tick"]["max_us"] for r in rs),
            "median_tick_avg_us": statistics.median(r["tick"]["avg_us"] for r in rs),
            "runs": rs,
        }
        for name, rs in runs.items()
    }


def _scenario(modules: list[ModuleSpec], ticks: int, repeats: int) -> dict[str, Any]:
    naive = resolve(modules, main_freq_hz=MAIN_FREQ_HZ, offsets="naive")
    balanced = naive.with_offsets("balanced")
    balanced_unit = resolve(_unit_costs(modules), main_freq_hz=MAIN_FREQ_HZ, offsets="balanced")
    static = {
        "naive": _static(naive),
        "balanced": _static(balanced),
        "balanced_unit_cost": _static(balanced_unit),
    }
    return {
        "static": static,
        "peak_functions_ratio_naive_over_balanced_unit_cost": round(
            static["naive"]["peak_functions_per_tick"]
            / static["balanced_unit_cost"]["peak_functions_per_tick"],
            4,
        ),
        "peak_cost_ratio_naive_over_balanced": round(
            static["naive"]["peak_cost_us_per_tick"] / static["balanced"]["peak_cost_us_per_tick"],
            4,
        ),
        "runtime": _runtime({"naive": naive, "balanced": balanced}, ticks, repeats),
    }


def main(argv: list[str] | None = None) -> int:
    parser = bench_parser(__doc__, REQUIRED)
    parser.add_argument("--ticks", type=int, default=5000, help="main-loop ticks per run")
    parser.add_argument("--repeats", type=int, default=3, help="runs per strategy (median)")
    parser.add_argument(
        "--heavy-scale",
        type=float,
        default=11.0,
        help="cost multiplier of the heavy scenario (11: naive peak > 2 ms > balanced peak)",
    )
    args = parser.parse_args(argv)

    modules = px4_like_modules()
    order = resolve(modules, main_freq_hz=MAIN_FREQ_HZ).module_order
    result = {
        "benchmark": "scheduler offsets, naive (seed 002) vs balanced",
        "main_freq_hz": MAIN_FREQ_HZ,
        "tick_period_us": 1e6 / MAIN_FREQ_HZ,
        "host": host(load_avg_1min_at_start=load_1min()),
        "module_order": list(order),
        "nominal": _scenario(modules, args.ticks, args.repeats),
        "heavy": {
            "cost_scale": args.heavy_scale,
            **_scenario(
                px4_like_modules(args.heavy_scale), max(1000, args.ticks // 2), args.repeats
            ),
        },
    }
    write_result(args.out, result)

    for name in ("nominal", "heavy"):
        scenario = result[name]
        assert isinstance(scenario, dict)
        s, r = scenario["static"], scenario["runtime"]
        print(
            f"{name}: peak functions/tick naive {s['naive']['peak_functions_per_tick']} "
            f"balanced {s['balanced']['peak_functions_per_tick']} "
            f"(unit-cost balanced {s['balanced_unit_cost']['peak_functions_per_tick']}), "
            f"mean {s['naive']['mean_functions_per_tick']}; "
            f"peak cost us naive {s['naive']['peak_cost_us_per_tick']} "
            f"balanced {s['balanced']['peak_cost_us_per_tick']}; "
            f"predicted overrun ticks/hyperperiod naive "
            f"{s['naive']['predicted_overrun_ticks_per_hyperperiod']} balanced "
            f"{s['balanced']['predicted_overrun_ticks_per_hyperperiod']}; median measured: "
            f"max tick duty us naive {r['naive']['median_tick_max_us']} "
            f"balanced {r['balanced']['median_tick_max_us']}, overruns naive "
            f"{r['naive']['median_overruns']} balanced {r['balanced']['median_overruns']}"
        )
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
