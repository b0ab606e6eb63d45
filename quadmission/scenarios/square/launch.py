"""The square as a launch file (``config/launch/square.yaml``): factories for its parts.

The same YAML runs in one process (``quadmission launch FILE``: the simulator steps every
node in lockstep) and under ROS 2 (``--transport ros2``: the simulator, the bridge and the
flight-control layer, and the mission script each in their own process, following
``/clock``). The factories take what a node cannot know by itself from the app, as
:mod:`quadmission.assembly.companion` does: the arena's field bounds for the flight-control node,
the square fitted to the arena for the pilot. The simulator factory builds the SITL
(:func:`sim.fcu.sitl.build_sitl`) and judges crashes; the pilot says when the mission is
over (:class:`~runtime.launch.Finishing`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from flight_control.flight_control_node import FlightControlNode
from quadmission.assembly.companion import field_bounds
from quadmission.scenarios.square.fit import fit_square
from quadmission.scenarios.square.flight import LAND_SPEED, SQUARE_SPEED
from quadmission.scenarios.square.pilot import SquarePilot
from runtime import DeterministicExecutor, Node
from runtime.launch import SimulationResult
from sim.arena import ArenaSpec, default_arena, load_arena
from sim.fcu.sitl import Sitl, build_sitl
from sim.world import Scene, StopWhen, WorldStatus

__all__ = ["LaunchedSquarePilot", "SitlSimulation", "flight_control", "launch_arena", "pop_arena",
           "sitl", "square_pilot"]


#: How long the pilot waits for the flight-control layer to report ready [s of simulated
#: time]. Under ros2 the bridge's time sync sees real round trips (a few ms), so it
#: converges later than in process (about 15 s against 5 s).
READY_TIMEOUT_S = 60.0


def launch_arena(arena: str | None) -> ArenaSpec:
    """The ``arena`` launch parameter's arena: an arena YAML, or the default arena."""
    return load_arena(arena) if arena else default_arena()


@dataclass
class _Tick:
    """A world part that calls ``tick(t_ns)`` at ``rate_hz`` of simulated time."""

    tick: Callable[[int], None]
    rate_hz: float
    name: str = "launch_tick"

    def update(self, t_ns: int, scene: Scene) -> None:
        self.tick(t_ns)


class SitlSimulation:
    """The SITL as a launch's simulator: a crash fails the launch, naming the reason."""

    def __init__(self, sitl: Sitl) -> None:
        self.sitl = sitl

    def run(self, limit_s: float, stop: Callable[[], bool],
            tick: Callable[[int], None] | None = None,
            tick_hz: float = 1000.0) -> SimulationResult:
        if tick is not None:  # the fastest rate up to tick_hz that divides the physics rate
            physics_hz = self.sitl.scene.physics_hz
            self.sitl.extra_parts.append(
                _Tick(tick, physics_hz / math.ceil(physics_hz / tick_hz)))
        result = self.sitl.run(limit_s, stop=StopWhen(stop))
        if result.crash is not None:
            return SimulationResult(1, f"CRASH: {result.crash.reason} at "
                                       f"{result.crash.t_s:.1f} s")
        if result.status is WorldStatus.STOPPED:
            return SimulationResult(0, f"stopped at {result.sim_time_s:.1f} s")
        return SimulationResult(1, f"time limit: {limit_s:g} s of simulated time passed")


def sitl(executor: DeterministicExecutor, *, arena: str | None = None,
         seed: int = 0) -> SitlSimulation:
    """The simulator factory: the quadrotor on the start pad, FCU booted, in ``arena``."""
    return SitlSimulation(build_sitl(launch_arena(arena), seed=seed, executor=executor))


def pop_arena(parameter_overrides: dict[str, Any] | None) -> tuple[ArenaSpec, dict[str, Any]]:
    """The ``arena`` launch parameter (an arena YAML; default arena when absent) and the
    node's own parameters."""
    rest = dict(parameter_overrides or {})
    return launch_arena(rest.pop("arena", None)), rest


def flight_control(*, parameter_overrides: dict[str, Any] | None = None,
                   **kwargs: Any) -> FlightControlNode:
    """The flight-control node with the arena's field as its flyable volume."""
    arena, rest = pop_arena(parameter_overrides)
    overrides = field_bounds(arena) | rest
    return FlightControlNode(parameter_overrides=overrides, **kwargs)


class LaunchedSquarePilot(SquarePilot):
    """The square pilot as a finishing node: exit code 0 after the landing, 1 on failure."""

    @property
    def exit_code(self) -> int | None:
        if self.outcome is None:
            return None
        return 0 if self.outcome.success else 1

    @property
    def exit_reason(self) -> str:
        if self.outcome is None:
            return "flying"
        return ("landed" if self.outcome.success
                else f"FAILED: {self.outcome.message}")


def square_pilot(*, parameter_overrides: dict[str, Any] | None = None,
                 **kwargs: Any) -> Node:
    """The mission script flying the square fitted to the ``arena`` parameter's arena."""
    arena, rest = pop_arena(parameter_overrides)
    if rest:
        raise ValueError(f"square_pilot takes only 'arena', got {sorted(rest)}")
    plan = fit_square(arena)
    return LaunchedSquarePilot(plan.corners(), altitude=plan.altitude, speed=SQUARE_SPEED,
                               land_speed=LAND_SPEED, ready_timeout_s=READY_TIMEOUT_S,
                               **kwargs)
