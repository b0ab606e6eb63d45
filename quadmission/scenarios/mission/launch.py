"""The mission as a launch file (``config/launch/mission.yaml``): factories for its parts.

The same YAML runs in one process (``quadmission launch FILE``: the simulator steps every
node in lockstep) and under ROS 2 (``--transport ros2``: the simulator with its cameras in
one process, the companion's nodes in a few groups, following ``/clock``). The nodes
are those :func:`quadmission.scenarios.mission.scenario.fly_mission` runs; the factories
give each what the
contest publishes before the run, as the scenario does: the field (flight control, the
path finder, the navigator), the pads and the start pad (the mission, the navigator, the
operator), the target robot (the mission), the robots' points tables (the operator).
Every factory takes the same ``arena`` launch parameter (an arena YAML; the default arena
when absent), so the simulator and the nodes agree on the field.

The mission node ends the launch (:class:`LaunchedMission`): exit code 0 once the
mission is ``completed``, 1 with the stop's reason otherwise. With ``until_state`` it
ends, with 0, as soon as the mission enters that state (a nested name or its prefix,
e.g. ``mission.explore``): a short check that the whole stack gets that far. Ground
truth is not judged here; ``quadmission sim --scenario mission`` writes the report.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from fsm.mission_machine import EventKind
from fsm.mission_node import MissionNode
from fsm.operator_node import OperatorNode
from navigation.navigator_node import NavigatorNode
from navigation.path_finder_node import PathFinderNode
from quadmission.assembly.companion import (
    check_mission_altitudes,
    check_turn_first_angle,
    navigator_overrides,
    planning_bounds,
)
from quadmission.assembly.faults import APP_KINDS, AppFaults
from quadmission.scenarios.mission.scenario import (
    flown_arena,
    pads_overrides,
    robots_overrides,
    target_robot,
)
from quadmission.scenarios.square.launch import SitlSimulation, launch_arena, pop_arena
from runtime import DeterministicExecutor, Node
from runtime.launch import SimulationResult
from sim.arena import ArenaSpec
from sim.fault_spec import Fault, parse_faults
from sim.faults import install_faults
from sim.fcu.sitl import build_sitl
from sim.render import SceneRenderer
from sim.sensors import ClockPublisher, SimSensorsNode, sensor_parts

__all__ = ["LaunchedMission", "MissionSimulation", "mission", "mission_sitl", "navigator",
           "operator", "path_finder", "sitl"]


class MissionSimulation(SitlSimulation):
    """The SITL with the contest drone's cameras (rendered while someone subscribes)."""

    def __init__(self, sitl: Any, sensors: SimSensorsNode, seed: int) -> None:
        super().__init__(sitl)
        self.sensors = sensors
        self.seed = seed

    def run(self, limit_s: float, stop: Callable[[], bool],
            tick: Callable[[int], None] | None = None,
            tick_hz: float = 1000.0) -> SimulationResult:
        scene = self.sitl.scene
        with SceneRenderer(scene.model) as renderer:
            parts = sensor_parts(self.sensors, renderer, scene, seed=self.seed)
            if tick is not None:  # a launch over processes: its lockstep publishes /clock;
                # the sensors' own, at the same times, would wake every node process twice
                parts = [part for part in parts if not isinstance(part, ClockPublisher)]
            self.sitl.extra_parts.extend(parts)
            try:
                return super().run(limit_s, stop, tick, tick_hz)
            finally:
                for part in parts:
                    self.sitl.extra_parts.remove(part)


def sitl(executor: DeterministicExecutor, *, arena: str | None = None, seed: int = 0,
         remove_pad: int | None = None, faults: list[str] | None = None) -> MissionSimulation:
    """The simulator: the SITL on the start pad and the cameras, in ``arena`` (without
    pad ``remove_pad``, which the mission still has on its map), with ``faults`` (specs,
    :mod:`sim.fault_spec`): the simulator's, and in process the app's (the executor
    runs every node then; under ros2 the launcher kills a stopped node's process)."""
    return mission_sitl(executor, flown_arena(launch_arena(arena), remove_pad), seed=seed,
                        faults=parse_faults(faults) if faults else ())


def mission_sitl(executor: DeterministicExecutor, flown: ArenaSpec, *, seed: int = 0,
                 faults: Sequence[Fault] = (), vehicle: bool = False) -> MissionSimulation:
    """The SITL and the cameras in the ``flown`` arena, with ``faults``. ``vehicle``: as a
    vehicle on the wall clock stands on the graph (``quadmission vehicle``): no ``/clock``,
    no modelled XRCE time-sync topics, only what PX4's agent, the cameras and a VIO
    carry."""
    sim = build_sitl(flown, seed=seed, executor=executor, session_topics=not vehicle)
    sensors = SimSensorsNode(clock=not vehicle, context=executor.context)
    executor.add_node(sensors)
    if faults:
        install_faults(sim, list(faults), sensors=sensors)
        app = [f for f in faults if f.kind in APP_KINDS]
        if app:
            sim.extra_parts.append(AppFaults(executor, app, None))
    return MissionSimulation(sim, sensors, seed)


def path_finder(*, parameter_overrides: dict[str, Any] | None = None,
                **kwargs: Any) -> PathFinderNode:
    """The path finder with the arena's field as its search volume."""
    arena, rest = pop_arena(parameter_overrides)
    return PathFinderNode(parameter_overrides=planning_bounds(arena) | rest, **kwargs)


def navigator(*, parameter_overrides: dict[str, Any] | None = None,
              **kwargs: Any) -> NavigatorNode:
    """The navigator with the arena's field, name and start pad."""
    arena, rest = pop_arena(parameter_overrides)
    node = NavigatorNode(parameter_overrides=navigator_overrides(arena) | rest, **kwargs)
    check_turn_first_angle(node.params)
    return node


def operator(*, parameter_overrides: dict[str, Any] | None = None,
             **kwargs: Any) -> OperatorNode:
    """The simulated operator with the arena's pads and the robots' points tables."""
    arena, rest = pop_arena(parameter_overrides)
    return OperatorNode(parameter_overrides=pads_overrides(arena) | robots_overrides(arena)
                        | rest, **kwargs)


class LaunchedMission(MissionNode):
    """The mission node as a finishing node: 0 once completed (or once ``until_state``
    is entered), 1 when the mission stops, with the reason."""

    def __init__(self, *, until_state: str | None = None, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.until_state = until_state
        self._reached: str | None = None  # the until_state entered

    def state_changed(self, state: str) -> None:
        super().state_changed(state)
        until = self.until_state
        if until and self._reached is None and (state == until
                                                 or state.startswith(until + ".")):
            self._reached = state

    @property
    def exit_code(self) -> int | None:
        if self._reached is not None:
            return 0
        if not self.mission.finished:
            return None
        return 0 if self.mission.state == "completed" and self.mission.stop is None else 1

    @property
    def exit_reason(self) -> str:
        m = self.mission
        if self._reached is not None:
            return f"reached {self._reached}"
        if not m.finished:
            return f"flying ({m.state})"
        landed = sum(1 for _, e in self.events if e.kind is EventKind.LANDED)
        summary = (f"score {m.score}, {landed} landings of the sequence "
                   f"{list(m.sequence)}")
        if m.state == "completed" and m.stop is None:
            return f"completed: {summary}"
        why = m.stop.describe() if m.stop is not None else m.state
        return f"STOPPED: {why}; {summary}"


def mission(*, parameter_overrides: dict[str, Any] | None = None,
            **kwargs: Any) -> Node:
    """The mission node with the arena's pads and its target robot (the ``target_robot``
    parameter when the arena has it, else config/mission.yaml's, else the first robot);
    ``until_state`` (a launch parameter) ends the launch when that state is entered."""
    arena, rest = pop_arena(parameter_overrides)
    until = rest.pop("until_state", None)
    target = target_robot(arena, rest.pop("target_robot", None))
    node = LaunchedMission(until_state=None if until is None else str(until),
                           parameter_overrides=pads_overrides(arena)
                           | {"target_robot": target} | rest, **kwargs)
    check_mission_altitudes(arena, node.params)
    return node
