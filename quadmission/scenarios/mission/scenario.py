"""The ``mission`` scenario: the whole contest through the real nodes (seed 003, 3.1).

The simulator (``sim.fcu.sitl``, the cameras) runs the FCU behind the serial link; the
companion is every node of the stack: the bridge, the VIO forwarder and flight control
(:func:`~quadmission.assembly.companion.start_companion`), the ArUco scanner, mapping, the path
finder, the navigator, precision landing, the mission state machine
(:class:`~fsm.mission_node.MissionNode`) and the simulated operator
(:class:`~fsm.operator_node.OperatorNode`). The app gives each what the contest
publishes before the run: the field, the pads, the start pad, the target robot, and to
the operator the robots' points tables. Nothing else crosses from the simulator.

The run ends when the state machine reaches a termination state or at
``MISSION_LIMIT_S``. After a landing it runs a few seconds more, so the last touchdown is
judged at rest; after a stop it ends there: the vehicle is the pilot's from then on (seed
003, 3.3.3), and a simulator has no pilot. Ground truth
is read only here, to judge it (:mod:`quadmission.evaluation.mission`): ``report.json`` (see
:func:`fly_mission`), ``path.png``, ``altitude.png``, ``timeline.png`` and the robot
pictures the operator received (``robot_<n>_raw.jpg``, ``robot_<n>_annotated.jpg``).

``--remove-pad ID`` takes the pad out of the simulated field while the mission and the
operator still have it on their map (seed 003, 4.2's lab run: the search branch, then a
skip with the reason). A ``script`` of :class:`Step` s presses the ground station's
buttons (pause, resume, abort, return home) or cuts the visual odometry mid-flight, as a
lost tracking would (the seed's rule: a stop, with no automatic landing).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from enum import Enum
from typing import TYPE_CHECKING, Any

import numpy as np

import interfaces
from flight_control.vio_node import VioNode
from fsm.mission_machine import EventKind
from fsm.mission_messages import COMMAND
from fsm.mission_node import MissionNode
from fsm.operator_node import OperatorNode
from fsm.params import MissionParams
from interfaces import graph
from navigation.mapping_node import MappingNode
from navigation.navigator_node import NavigatorNode
from navigation.path_finder_node import PathFinderNode
from navigation.precision_land_node import PrecisionLandNode
from perception.aruco_scanner_node import ArucoScannerNode
from quadmission.assembly.companion import (
    check_mission_altitudes,
    check_turn_first_angle,
    navigator_overrides,
    planning_bounds,
    start_companion,
)
from quadmission.assembly.faults import AppFaults, check_faults, resolve_faults
from quadmission.assembly.services import attach_services
from quadmission.errors import OptionsError
from quadmission.evaluation.faults import FAULT_SETTLE_S, FcuFailsafes, end_state, judge_fault
from quadmission.evaluation.mission import Landing, distance_m, landing, score, touchdown_summary
from quadmission.evaluation.tracking import SetpointRecorder, rounded, tracking
from quadmission.reports.mission_plots import (
    MissionPicture,
    save_altitude,
    save_path,
    save_timeline,
)
from quadmission.reports.report import write_report
from runtime import Node
from runtime.parameters import load_parameters
from sim.arena import ArenaSpec, robot_pose
from sim.faults import install_faults
from sim.fcu.sitl import build_sitl
from sim.render import SceneRenderer
from sim.sensors import SimSensorsNode, sensor_parts
from sim.world import Scene, StopWhen, Trajectory

if TYPE_CHECKING:
    from quadmission.scenarios.options import ScenarioOptions

MISSION_LIMIT_S = 1800.0  # s of simulated time before the run is declared stuck
SETTLE_S = 3.0  # s flown on after the end, so the last touchdown is judged at rest
PROGRESS_EVERY_S = 10.0  # s of simulated time between progress lines
PICTURES = {"path": "path.png", "altitude": "altitude.png", "timeline": "timeline.png"}


def flown_arena(published: ArenaSpec, remove_pad: int | None) -> ArenaSpec:
    """The field the simulator builds: the published one, without ``remove_pad``."""
    if remove_pad is None:
        return published
    if remove_pad not in published.pad_ids:
        raise OptionsError(f"--remove-pad {remove_pad}: arena {published.name!r} has pads "
                           f"{list(published.pad_ids)}")
    if remove_pad == published.start_pad:
        raise OptionsError(f"--remove-pad {remove_pad}: the drone takes off from it")
    return replace(
        published, pads=tuple(p for p in published.pads if p.id != remove_pad),
        robots=tuple(replace(r, points=tuple(kv for kv in r.points if kv[0] != remove_pad))
                     for r in published.robots))


def target_robot(arena: ArenaSpec, asked: int | None) -> int:
    """The robot to find: the one asked for, else config/mission.yaml's when the arena
    has it, else the arena's first robot."""
    ids = [r.marker_id for r in arena.robots]
    if asked is not None:
        if asked not in ids:
            raise OptionsError(f"--target-robot {asked}: arena {arena.name!r} has robots {ids}")
        return asked
    configured = load_parameters(MissionParams, "mission").target_robot
    return configured if configured in ids else ids[0]


def pads_overrides(arena: ArenaSpec) -> dict[str, Any]:
    """The pads as the contest publishes them, for the mission and the operator."""
    return {"pad_ids": [p.id for p in arena.pads],
            "pad_x": [float(p.center[0]) for p in arena.pads],
            "pad_y": [float(p.center[1]) for p in arena.pads],
            "start_pad": arena.start_pad}


def robots_overrides(arena: ArenaSpec) -> dict[str, Any]:
    """What each robot carries, for the operator: one row of points per robot."""
    return {"robot_ids": [r.marker_id for r in arena.robots],
            "robot_points": [r.points_table.get(p.id, 0) for r in arena.robots
                             for p in arena.pads]}


@dataclass
class _Progress:
    """A world part that tells the state and the sim time as the mission goes."""

    mission: MissionNode
    say: Callable[[str], None]
    name: str = "progress"
    rate_hz: float = 10.0
    _last: str = ""
    _next_s: float = 0.0

    def update(self, t_ns: int, scene: Scene) -> None:
        t, m = t_ns / 1e9, self.mission.mission
        if m.state != self._last or t >= self._next_s:
            pad = f" pad {m.target_pad}" if m.target_pad else ""
            self.say(f"  t={t:6.1f} s  {m.state}{pad}  score {m.score}")
            self._last = m.state
            self._next_s = math.floor(t / PROGRESS_EVERY_S + 1.0) * PROGRESS_EVERY_S


class Act(Enum):
    """What a scripted step does: an operator command, or a fault."""

    PAUSE = "pause"
    RESUME = "resume"
    ABORT = "abort"
    RETURN_HOME = "return_home"
    CUT_VIO = "cut_vio"  # the visual odometry stops, as a lost tracking would


@dataclass(frozen=True)
class Step:
    """``act`` once the mission has been in ``state`` (a nested name or a prefix of one)
    for ``after_s`` seconds; each step fires once, in order."""

    state: str
    after_s: float
    act: Act


_COMMAND_OF = {Act.PAUSE: "COMMAND_PAUSE", Act.RESUME: "COMMAND_RESUME",
               Act.ABORT: "COMMAND_ABORT", Act.RETURN_HOME: "COMMAND_RETURN_HOME"}


class ScriptedOperator(Node):
    """The ground station's buttons, pressed by a script (tests, fault runs): publishes
    MissionCommand on /mission/command like the page does."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("scripted_operator", **kwargs)
        command = graph.MISSION_COMMAND
        self.pub = self.create_publisher(command.type, command.name, command.qos)

    def press(self, act: Act) -> None:
        msg = interfaces.new(COMMAND, command=int(getattr(COMMAND, _COMMAND_OF[act])),
                             reason=f"script: {act.value}")
        msg.header.stamp = self.now().to_msg()
        self.pub.publish(msg)


@dataclass
class _Script:
    """A world part that plays :class:`Step` s against the mission's state."""

    mission: MissionNode
    buttons: ScriptedOperator
    vio: VioNode
    steps: list[Step]
    name: str = "script"
    rate_hz: float = 10.0
    played: list[tuple[float, Step]] = field(default_factory=list)

    def update(self, t_ns: int, scene: Scene) -> None:
        if len(self.played) == len(self.steps):
            return
        step = self.steps[len(self.played)]
        entered, state = self.mission.timeline[-1]
        t = t_ns / 1e9
        if not (state == step.state or state.startswith(step.state + ".")):
            return
        if t - entered < step.after_s:
            return
        if step.act is Act.CUT_VIO:
            self.vio.set_tracking(False)
        else:
            self.buttons.press(step.act)
        self.played.append((t, step))


def _first_event_s(node: MissionNode, kind: EventKind) -> float | None:
    return next((t for t, e in node.events if e.kind is kind), None)


def _state_entered_s(node: MissionNode, prefix: str) -> float | None:
    return next((t for t, s in node.timeline if s == prefix or s.startswith(prefix + ".")),
                None)


def fly_mission(options: ScenarioOptions, *, script: Sequence[Step] = (),
                limit_s: float = MISSION_LIMIT_S,
                operator_overrides: dict[str, Any] | None = None) -> dict[str, Any]:
    """Fly the contest; write report.json, the pictures and the robot pictures into
    ``options.out``; return the report.

    ``report.json``: ``result`` (completed | stopped) and ``reason``; ``score`` (true
    touchdowns inside their pad, the target robot's true table), ``max_score`` (the table's
    total) and ``plan`` (the operator's exact and greedy sequences with their points,
    costs and budget); ``robot_found_s``; ``landings`` [{pad, touchdown_xy_m,
    touchdown_error_m, inside_pad, t_s}]; ``pads_skipped`` [{pad, reason}]; ``distance_m``,
    ``flight_time_s``; ``rmse_m`` {x, y, z} (setpoint vs flown); ``crashed``; ``states``
    [{t_s, state}]; ``host`` {wall_time_s, rtf}. Same seed, same report but ``host``.
    With ``options.faults`` (:mod:`sim.fault_spec`): ``faults`` [{kind, at_s, duration_s,
    spec, expected, observed, reaction_s, end_state, handled}]
    (:func:`quadmission.evaluation.faults.judge_fault`).
    ``script``: operator commands and faults played against the mission's states;
    ``operator_overrides``: the simulated operator's parameters (e.g. a shorter
    ``mission_time_s`` for a short sequence).
    """
    published = options.load_arena()  # also written to out/arena.yaml
    arena = flown_arena(published, options.remove_pad)
    target = target_robot(published, options.target_robot)
    sitl = build_sitl(arena, seed=options.seed)
    companion = start_companion(sitl)
    context = sitl.executor.context
    pads = pads_overrides(published)
    sensors = SimSensorsNode(context=context)
    nodes = [
        sensors,
        ArucoScannerNode(context=context),
        MappingNode(context=context),
        PathFinderNode(context=context, parameter_overrides=planning_bounds(arena)),
        navigator := NavigatorNode(context=context,
                                   parameter_overrides=navigator_overrides(published)),
        PrecisionLandNode(context=context),
        mission := MissionNode(context=context, parameter_overrides=pads | {
            "target_robot": target}),
        operator := OperatorNode(context=context, parameter_overrides=pads
                                 | robots_overrides(published) | (operator_overrides or {})),
        recorder := SetpointRecorder(context=context),
        buttons := ScriptedOperator(context=context),
    ]
    check_mission_altitudes(arena, mission.params)
    check_turn_first_angle(navigator.params)
    for node in nodes:
        sitl.executor.add_node(node)
    check_faults("mission", options.faults)
    faults = resolve_faults(options.faults, arena, target,
                            [n.get_name() for n in sitl.executor.context.nodes])
    options.progress(f"  target robot {target}, start pad {published.start_pad}"
                     + (f", pad {options.remove_pad} removed" if options.remove_pad else ""))
    with SceneRenderer(sitl.scene.model) as renderer, \
            attach_services(options, sitl.executor, sitl.extra_parts, sitl.scene.arena, sitl.scene):
        sitl.extra_parts.extend(sensor_parts(sensors, renderer, sitl.scene, seed=options.seed))
        sitl.extra_parts.append(_Progress(mission, options.progress))
        played = _Script(mission, buttons, companion.vio, list(script))
        sitl.extra_parts.append(played)
        failsafes = FcuFailsafes(sitl.firmware)
        if faults:  # a run without faults keeps the parts it had
            install_faults(sitl, faults, sensors=sensors)
            sitl.extra_parts.append(failsafes)
            sitl.extra_parts.append(AppFaults(sitl.executor, faults,
                                              lambda: buttons.press(Act.ABORT)))
        result = sitl.run(limit_s, stop=StopWhen(lambda: mission.mission.finished))
        runs = [result]
        if result.crash is None and mission.mission.state != "stopped":
            runs.append(sitl.run(SETTLE_S))  # on the ground: judge the touchdown at rest
        elif result.crash is None and options.faults:  # stopped by a fault's reaction: fly
            runs.append(sitl.run(FAULT_SETTLE_S))  # on, so the end state is where it settles
    truth = Trajectory(*(np.concatenate([getattr(r.trajectory, f) for r in runs])
                         for f in ("t", "position", "quaternion", "velocity")))
    crash = next((r.crash for r in runs if r.crash is not None), None)
    wall_s = sum(r.wall_time_s for r in runs)
    sim_s = sum(r.sim_time_s for r in runs)
    m = mission.mission
    end_s = crash.t_s if crash is not None else sim_s

    landed_events = [(t, e.marker_id) for t, e in mission.events if e.kind is EventKind.LANDED]
    landings: list[Landing] = [landing(published, pad, t, truth) for t, pad in landed_events]
    table = next(r.points_table for r in published.robots if r.marker_id == target)
    true_score = score(landings, table)
    decision = operator.decision
    takeoff_s = _state_entered_s(mission, "mission.takeoff")
    final_s = mission.timeline[-1][0] if m.finished else end_s
    window = (takeoff_s if takeoff_s is not None else end_s, final_s)
    stamps, setpoints = recorder.samples()
    track = tracking(stamps, setpoints, truth, window)
    rmse = {k: rounded(v) for k, v in track.rmse().items() if k in ("x", "y", "z")}
    found_s = _first_event_s(mission, EventKind.ROBOT_FOUND)
    completed = m.state == "completed" and crash is None
    reason = None
    if crash is not None:
        reason = f"crash: {crash.reason} at {crash.t_s:.1f} s"
    elif not m.finished:
        reason = f"not finished after {limit_s:g} s (state {m.state})"
    elif m.stop is not None:
        reason = m.stop.describe()
    inside = sum(d.inside for d in landings)
    planned = decision.exact if decision is not None else None
    expected_skips = {options.remove_pad} if options.remove_pad is not None else set()
    # the contest's success: completed, every pad of the sequence landed inside (a pad
    # taken out of the field on purpose is skipped instead), no crash
    ok = (completed and bool(m.sequence) and inside == len(landings)
          and {s.pad for s in m.skipped} <= expected_skips
          and len(landings) + len(m.skipped) == len(m.sequence))
    verdict = (f"{'completed' if completed else 'STOPPED'}: score {true_score}"
               + (f"/{planned.points} planned" if planned else "")
               + f", {inside}/{len(landings)} landings inside"
               + (f", skipped {[s.pad for s in m.skipped]}" if m.skipped else "")
               + ("" if reason is None else f" ({reason})"))

    robot_xy = None
    if found_s is not None:
        robot = next(r for r in arena.robots if r.marker_id == target)
        x, y = robot_pose(robot, found_s).xy
        robot_xy = (float(x), float(y))
    picture = MissionPicture(
        title=f"arena {published.name}, seed {options.seed}: {verdict}",
        went_wrong=not ok, arena=published, altitude=mission.params.cruise_altitude,
        setpoint_t=stamps, setpoint=setpoints, truth=truth, landings=landings,
        sequence=list(m.sequence), robot_xy=robot_xy, robot_id=target,
        timeline=mission.timeline, end_s=max(end_s, 1.0), removed_pad=options.remove_pad,
        crash=crash)
    save_path(options.out / PICTURES["path"], picture)
    save_altitude(options.out / PICTURES["altitude"], picture)
    save_timeline(options.out / PICTURES["timeline"], picture)
    robot_pictures = _save_robot_pictures(options, operator)

    report = {
        "scenario": "mission", "arena": published.name, "seed": options.seed,
        "random_arena": options.random_arena, "lighting": published.lighting.value,
        "start_pad": published.start_pad, "target_robot": target,
        "removed_pad": options.remove_pad,
        "script": [{"t_s": rounded(t, 3), "state": st.state, "after_s": st.after_s,
                    "act": st.act.value} for t, st in played.played],
        "verdict": verdict, "ok": ok,
        "result": "completed" if completed else "stopped", "reason": reason,
        "final_state": m.state,
        "score": true_score, "max_score": sum(table.values()),
        "mission_score": m.score,
        "score_equals_plan": planned is not None and true_score == planned.points,
        "plan": None if decision is None else {
            "robot": decision.robot,
            "sequence": list(decision.exact.pads), "points": decision.exact.points,
            "cost_s": rounded(decision.exact.cost, 2),
            "greedy": {"sequence": list(decision.greedy.pads),
                       "points": decision.greedy.points,
                       "cost_s": rounded(decision.greedy.cost, 2)},
            "budget_s": rounded(decision.problem.budget, 2),
            "time_left_s": rounded(decision.time_left_s, 2),
            "battery_remaining": rounded(decision.battery_remaining, 4),
            "decided_at_s": rounded(decision.decided_at_s, 2)},
        "sequence": list(m.sequence),
        "robot_found_s": rounded(found_s, 2),
        "landings": [d.to_json() for d in landings],
        **touchdown_summary(landings),
        "pads_skipped": [{"pad": s.pad, "reason": s.reason} for s in m.skipped],
        "distance_m": rounded(distance_m(truth, window), 2),
        "flight_time_s": None if takeoff_s is None else rounded(final_s - takeoff_s, 2),
        "rmse_m": rmse,
        "crashed": crash is not None,
        "crash": None if crash is None else {"reason": crash.reason, "t_s": rounded(crash.t_s, 3),
                                             "position_m": [rounded(v, 3) for v in crash.position]},
        "states": [{"t_s": rounded(t, 3), "state": s} for t, s in mission.timeline],
        "sim_time_s": rounded(sim_s, 3),
        "pictures": PICTURES, "robot_pictures": robot_pictures,
        "host": {"wall_time_s": rounded(wall_s, 2),
                 "rtf": rounded(sim_s / wall_s if wall_s > 0 else None, 2)},
    }
    if faults:
        ended = end_state(truth, arena, sitl.scene.quad.leg_height, crash)
        skips = [(t, e.marker_id, e.message) for t, e in mission.events
                 if e.kind is EventKind.PAD_SKIPPED]
        report["faults"] = [judge_fault(f, mission.events, failsafes.entered_s, ended, skips,
                                        completed=completed and inside == len(landings))
                            for f in faults]
    write_report(options.out, report)
    return report


def _save_robot_pictures(options: ScenarioOptions, operator: OperatorNode) -> list[str]:
    """The JPEGs the operator received, as files."""
    names: list[str] = []
    for i, msg in enumerate(operator.pictures, start=1):
        for kind in ("raw", "annotated"):
            data = bytes(getattr(msg, f"picture_{kind}").data)
            if data:
                name = f"robot_{i}_{kind}.jpg"
                (options.out / name).write_bytes(data)
                names.append(name)
    return names


def mission_scenario(options: ScenarioOptions) -> dict[str, Any]:
    """The ``mission`` scenario (see the module docstring)."""
    return fly_mission(options)


__all__ = ["MISSION_LIMIT_S", "Act", "ScriptedOperator", "Step", "flown_arena", "fly_mission",
           "mission_scenario", "pads_overrides", "robots_overrides", "target_robot"]
