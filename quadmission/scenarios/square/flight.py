"""The ``square`` scenario: the real companion stack flies a square over the SITL.

The simulator (``sim.fcu.sitl``) runs the FCU behind the serial link; the companion
(:func:`quadmission.assembly.companion.start_companion`) adds the time-synchronised bridge, the VIO
forwarder and the flight-control node; :class:`~quadmission.scenarios.square.pilot.SquarePilot`,
a mission script, drives the flight-control layer's services and actions. The square
comes from :func:`~quadmission.scenarios.square.fit.fit_square` (or is given, for tests that need
a flight to go wrong). Ground truth is read only here, to judge the flight:

- ``report.json``: strict JSON (no NaN; null when unknown). Everything is a function of
  the seed and the arena, except the ``host`` block (wall time, real-time factor, FCU
  scheduler overruns against host time);
- ``path.png`` (:mod:`quadmission.reports.plots`), written whatever the outcome;
- the verdict: ``landed, RMSE 0.05 m`` (the true path against the planned outline, see
  :func:`~quadmission.evaluation.tracking.outline_tracking`) / ``CRASH: hit obstacle_2 at 18.9 s`` /
  ``FAILED: ...``; a square that does not fit is refused before any flight
  (:class:`~quadmission.errors.SquareDoesNotFit`, ``REFUSED: ...``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum
from typing import TYPE_CHECKING, Any

import numpy as np

from quadmission.assembly.companion import start_companion
from quadmission.assembly.services import attach_services
from quadmission.errors import SquareDoesNotFit
from quadmission.evaluation.faults import FAULT_SETTLE_S, FcuFailsafes, end_state, judge_fault
from quadmission.evaluation.tracking import SetpointRecorder, outline_tracking, rounded
from quadmission.reports.plots import FlightPicture, save_path_figure
from quadmission.reports.report import write_report
from quadmission.scenarios.square.fit import CLEARANCE, SquarePlan, fit_square
from quadmission.scenarios.square.pilot import PilotPhase, SquarePilot
from quadmission.scenarios.square.status import SquareStatusNode
from sim.arena import ArenaSpec
from sim.faults import install_faults
from sim.fcu.link import LinkDirection
from sim.fcu.sitl import Sitl, build_sitl
from sim.world import Scene, StopWhen, Trajectory

if TYPE_CHECKING:
    from quadmission.scenarios.options import ScenarioOptions

SQUARE_SPEED = 0.8  # m/s, cruise speed of each leg
LAND_SPEED = 0.5  # m/s, offboard descent to the touchdown
FLIGHT_LIMIT_S = 240.0  # s of simulated time before the flight is declared stuck
PROGRESS_EVERY_S = 5.0  # s of simulated time between progress lines
PATH_IMAGE = "path.png"


class Verdict(Enum):
    """How a square flight is judged (the report's ``outcome``): not a policy's goal
    outcome but the scenario's verdict on the whole flight, ground truth included."""

    LANDED = "landed"
    CRASH = "crash"
    FAILED = "failed"
    REFUSED = "refused"


@dataclass
class _Progress:
    """A world part that tells the sim time and the pilot's step as the flight goes."""

    pilot: SquarePilot
    say: Callable[[str], None]
    name: str = "progress"
    rate_hz: float = 10.0
    _last: tuple[PilotPhase, int] | None = None
    _next_s: float = 0.0

    def update(self, t_ns: int, scene: Scene) -> None:
        t = t_ns / 1e9
        step = (self.pilot.phase, self.pilot.corner_index)
        if step != self._last or t >= self._next_s:
            what = self.pilot.phase.value
            if self.pilot.phase is PilotPhase.SQUARE:
                what += f" (corner {self.pilot.corner_index + 1}/{len(self.pilot.corners)})"
            self.say(f"  t={t:6.1f} s  {what}")
            self._last = step
            self._next_s = math.floor(t / PROGRESS_EVERY_S + 1.0) * PROGRESS_EVERY_S


def _rmse_line(rmse: dict[str, float | None]) -> str:
    if rmse["xy"] is None:
        return "no tracking RMSE: the square was not flown"
    values = "/".join(f"{rmse[axis]:.3f}" for axis in ("x", "y", "z", "xy"))
    return f"tracking RMSE x/y/z/xy {values} m (ground truth vs the planned outline)"


def _base_report(options: ScenarioOptions, arena: ArenaSpec) -> dict[str, Any]:
    return {"scenario": "square", "arena": arena.name, "seed": options.seed,
            "random_arena": options.random_arena, "start_pad": arena.start_pad}


def refused_report(options: ScenarioOptions, arena: ArenaSpec,
                   reason: str) -> dict[str, Any]:
    """The report of a square that was not flown."""
    return _base_report(options, arena) | {
        "outcome": Verdict.REFUSED.value, "verdict": f"REFUSED: {reason}", "landed": False,
        "ok": False, "refused": reason, "square": None, "tracking": None, "crash": None,
        "path_image": None,
    }


def _plan_json(plan: SquarePlan, speed: float) -> dict[str, Any]:
    return {"side_m": plan.side, "altitude_m": plan.altitude, "speed_m_s": speed,
            "clearance_m": round(CLEARANCE, 3), "direction": list(plan.direction),
            "start_m": list(plan.start), "corners_m": [list(c) for c in plan.corners()]}


def fly_square(options: ScenarioOptions, arena: ArenaSpec, plan: SquarePlan, *,
               speed: float = SQUARE_SPEED, limit_s: float = FLIGHT_LIMIT_S,
               physics_hz: int | None = None,
               setup: Callable[[Sitl], None] | None = None) -> dict[str, Any]:
    """Fly ``plan`` in ``arena`` through the companion stack, as given (no fit check);
    write report.json and path.png into ``options.out``; return the report.

    ``physics_hz`` overrides ``config/sim_world.yaml``'s; ``setup(sitl)`` adds nodes or
    parts before the flight (benchmarks add a camera and its subscriber)."""
    options.out.mkdir(parents=True, exist_ok=True)
    sitl = build_sitl(arena, seed=options.seed, physics_hz=physics_hz)
    start_companion(sitl)
    context = sitl.executor.context
    pilot = SquarePilot(plan.corners(), altitude=plan.altitude, speed=speed,
                        land_speed=LAND_SPEED, context=context)
    recorder = SetpointRecorder(context=context)
    status = SquareStatusNode(pilot, plan.outline(), context=context)
    for node in (pilot, recorder, status):
        sitl.executor.add_node(node)
    sitl.extra_parts.append(_Progress(pilot, options.progress))
    if setup is not None:
        setup(sitl)
    failsafes = FcuFailsafes(sitl.firmware)
    if options.faults:  # as the mission does; a run without faults keeps the parts it had
        install_faults(sitl, options.faults)
        sitl.extra_parts.append(failsafes)
    with attach_services(options, sitl.executor, sitl.extra_parts, arena, sitl.scene):
        runs = [sitl.run(limit_s, stop=StopWhen(lambda: pilot.done))]
        landed = pilot.outcome is not None and pilot.outcome.success
        if options.faults and runs[0].crash is None and not landed:
            runs.append(sitl.run(FAULT_SETTLE_S))  # as the mission: where it comes to rest
    result = runs[0]
    truth = Trajectory(*(np.concatenate([getattr(r.trajectory, f) for r in runs])
                         for f in ("t", "position", "quaternion", "velocity")))
    crash = next((r.crash for r in runs if r.crash is not None), None)
    end_s = crash.t_s if crash is not None else result.sim_time_s

    started = {phase: ns / 1e9 for phase, ns in pilot.phase_started_ns.items()}
    square_end_s = min(started.get(PilotPhase.LAND, math.inf),
                       started.get(PilotPhase.FAILED, math.inf), end_s)
    window = (started.get(PilotPhase.SQUARE, math.inf), square_end_s)
    stamps, setpoints = recorder.samples()  # drawn, not judged: they may cut corners
    track = outline_tracking(truth, plan.outline(), plan.altitude, window)
    rmse = {axis: rounded(v) for axis, v in track.rmse().items()}  # as reported

    outcome = pilot.outcome
    if crash is not None:
        verdict_kind = Verdict.CRASH
        verdict = f"CRASH: {crash.reason} at {crash.t_s:.1f} s"
    elif outcome is not None and outcome.success:
        verdict_kind = Verdict.LANDED
        xy = rmse["xy"]
        verdict = "landed, RMSE " + ("n/a" if xy is None else f"{xy:.3f} m")
    else:
        verdict_kind = Verdict.FAILED
        why = outcome.message if outcome is not None else (
            f"not finished after {limit_s:g} s of simulated time (step {pilot.phase.value})")
        verdict = f"FAILED: {why}"
    takeoff_s = started.get(PilotPhase.TAKEOFF)
    flight_end_s = started.get(PilotPhase.DONE, end_s)

    title = f"square, arena {arena.name}, seed {options.seed}: {verdict}\n{_rmse_line(rmse)}"
    save_path_figure(options.out / PATH_IMAGE, FlightPicture(
        title=title, went_wrong=verdict_kind is not Verdict.LANDED, arena=arena,
        altitude=plan.altitude, plan=plan.outline(),
        setpoint_t=stamps, setpoint=setpoints, truth=truth, tracking=track, crash=crash))

    landed = verdict_kind is Verdict.LANDED
    report = _base_report(options, arena) | {
        "outcome": verdict_kind.value,
        "verdict": verdict,
        "landed": landed,
        "ok": landed,
        "square": _plan_json(plan, speed),
        "tracking": {
            "reference": "the planned outline: each true position during the square (first "
                         "reach to land) against the nearest point of the square's edges at "
                         "its altitude",
            "window_s": [rounded(window[0]), rounded(window[1])],
            "samples": len(track.t),
            "rmse_m": rmse,
            "max_error_m": rounded(track.max_error()),
        },
        "crash": None if crash is None else {
            "reason": crash.reason, "t_s": rounded(crash.t_s, 3),
            "position_m": [rounded(v, 3) for v in crash.position]},
        "pilot": {"phase": pilot.phase.value,
                  "success": None if outcome is None else outcome.success,
                  "message": None if outcome is None else outcome.message},
        "flight_time_s": None if takeoff_s is None else rounded(flight_end_s - takeoff_s, 3),
        "sim_time_s": rounded(sum(r.sim_time_s for r in runs), 3),
        "link": {d.name.lower(): {"sent": c.sent, "lost": c.lost, "spikes": c.spikes}
                 for d in LinkDirection for c in [sitl.link.counters(d)]},
        "path_image": PATH_IMAGE,
        "host": {"wall_time_s": rounded(result.wall_time_s, 2),
                 "real_time_factor": rounded(result.real_time_factor, 2),
                 "cpu_time_s": rounded(result.cpu_time_s, 2),
                 "fcu_overruns": sitl.firmware.scheduler.report().overruns},
    }
    if options.faults:  # no mission here: the FCU's failsafes and riding it out
        ended = end_state(truth, arena, sitl.scene.quad.leg_height, crash)
        report["faults"] = [judge_fault(f, (), failsafes.entered_s, ended, mission=False)
                            for f in options.faults]
    write_report(options.out, report)
    return report


def square(options: ScenarioOptions) -> dict[str, Any]:
    """Fit the square to the arena from its start pad, then fly it through the companion
    stack (:func:`fly_square`). Raises :class:`SquareDoesNotFit` (after writing the
    refused report) when no square keeps clear of the walls and obstacles."""
    arena = options.load_arena()
    try:
        plan = fit_square(arena)
    except SquareDoesNotFit as exc:
        write_report(options.out, refused_report(options, arena, str(exc)))
        raise
    options.progress(f"  flying a {plan.describe()}")
    return fly_square(options, arena, plan)


__all__ = ["FLIGHT_LIMIT_S", "SQUARE_SPEED", "Verdict", "fly_square", "refused_report",
           "square"]
