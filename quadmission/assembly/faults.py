"""Faults in a scenario: which kinds each scenario takes, and the ones the app plays.

The simulator's kinds act through :func:`sim.faults.install_faults`; the rest act outside
the companion under test, here: the operator (``operator_abort``: ABORT pressed;
``operator_silent``: the operator stops answering) and the processes (``node_stop``: the
deterministic executor stops executing the node, as if its process had died, and with a
duration starts a fresh instance of it that much later, as a respawned process; under the
``ros2`` transport the launcher kills the process and the launch file's ``respawn`` says
whether it comes back, :mod:`runtime.processes.launcher`).

A scenario takes a kind when the kind acts on something it flies and the expected
reaction (:mod:`quadmission.evaluation.faults`) can happen in it: the mission's policy
needs the mission, so the kinds the mission must notice are the mission scenario's only.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

from quadmission.errors import OptionsError
from quadmission.evaluation.faults import (
    FaultExpectationError,
    FcuFailsafes,
    end_state,
    expectation,
    judge_fault,
)
from runtime import DeterministicExecutor
from sim.arena import ArenaSpec
from sim.fault_spec import Fault, FaultKind
from sim.world import Crash, Scene, Trajectory

__all__ = ["APP_KINDS", "SCENARIO_KINDS", "AppFaults", "check_faults", "judge_flight",
           "resolve_faults"]

APP_KINDS = frozenset({FaultKind.OPERATOR_ABORT, FaultKind.OPERATOR_SILENT,
                       FaultKind.NODE_STOP})
"""The kinds played here (not in the simulator)."""

_FLYING = frozenset({FaultKind.LINK_LOST, FaultKind.WIND_GUST, FaultKind.VIO_JUMP,
                     FaultKind.VIO_DELAY, FaultKind.LATENCY_SPIKE, FaultKind.PACKET_BURST,
                     FaultKind.CLOCK_JUMP, FaultKind.ROBOT_ACROSS})
"""Kinds any flight over the SITL can take: the FCU's failsafe, or nobody, reacts."""

SCENARIO_KINDS: dict[str, frozenset[FaultKind]] = {
    "mission": frozenset(FaultKind),
    "navigate": _FLYING | {FaultKind.DEPTH_DARK, FaultKind.LIGHT_DROP},
    "map-arena": _FLYING | {FaultKind.DEPTH_DARK, FaultKind.LIGHT_DROP},
    "precision-landing": _FLYING | {FaultKind.CAMERA_DARK, FaultKind.PAD_OCCLUDED,
                                    FaultKind.LIGHT_DROP},
    # no mission: vio_stop is judged not handled (nobody holds), and lost for good it
    # shows the FCU's position-loss descent on its own
    "square": _FLYING | {FaultKind.VIO_STOP},
}
"""What each scenario takes; the others take none."""

_WHY_NOT = {
    FaultKind.VIO_STOP: "its expected reaction is the mission's HOLD",
    FaultKind.BATTERY_LOW: "its expected reaction is the mission's RETURN_AND_LAND",
    FaultKind.BATTERY_CRITICAL: "its expected reaction is the mission's LAND_NOW",
    FaultKind.OPERATOR_ABORT: "there is no operator",
    FaultKind.OPERATOR_SILENT: "there is no operator",
    FaultKind.ROBOT_ABSENT: "no robot is searched for",
    FaultKind.NODE_STOP: "its expected reaction is the mission's watchdog's",
    FaultKind.CAMERA_DARK: "nothing in it uses the down camera",
    FaultKind.PAD_OCCLUDED: "it lands on no pad",
    FaultKind.DEPTH_DARK: "nothing in it uses the depth camera",
}


def check_faults(scenario: str, faults: Sequence[Fault]) -> None:
    """Refuse, naming the scenario and the kind, a fault the scenario cannot take."""
    if not faults:
        return
    takes = SCENARIO_KINDS.get(scenario)
    if takes is None:
        raise OptionsError(f"--fault/--faults: the {scenario} scenario takes no faults")
    for f in faults:
        if f.kind not in takes:
            why = _WHY_NOT.get(f.kind, "it does not fly what the fault acts on")
            kinds = ", ".join(sorted(k.value for k in takes))
            raise OptionsError(f"--fault {f.spec()}: the {scenario} scenario cannot take "
                               f"{f.kind.value} ({why}); it takes: {kinds}")


def resolve_faults(faults: Sequence[Fault], arena: ArenaSpec, target_robot: int | None,
                   nodes: Sequence[str]) -> tuple[Fault, ...]:
    """The faults with what the app knows filled in (``robot_absent``: the target robot)
    and checked against the run (``node_stop``: a node of the run with an expected
    reaction); an error names the fault."""
    out = []
    for f in faults:
        if f.kind is FaultKind.ROBOT_ABSENT and math.isnan(f.value("robot")):
            if target_robot is None:
                raise OptionsError(f"--fault {f.spec()}: name the robot (robot=ID)")
            f = replace(f, values=(("robot", float(target_robot)),))
        if f.kind is FaultKind.NODE_STOP:
            name = f.text("name")
            if name not in nodes:
                raise OptionsError(f"--fault {f.spec()}: no node {name!r} in this run "
                                   f"(nodes: {', '.join(sorted(nodes))})")
            try:
                expectation(f)
            except FaultExpectationError as exc:
                raise OptionsError(f"--fault {exc}") from None
        out.append(f)
    if any(f.kind is FaultKind.PAD_OCCLUDED and int(f.value("pad")) not in arena.pad_ids
           for f in out):
        raise OptionsError(f"--fault pad_occluded: arena {arena.name!r} has pads "
                           f"{list(arena.pad_ids)}")
    return tuple(out)


@dataclass
class AppFaults:
    """A world part that plays the app's faults at their times: ABORT pressed, the
    operator silenced, a node stopped (and restarted at the end of its duration)."""

    executor: DeterministicExecutor
    faults: Sequence[Fault]
    press_abort: Callable[[], None] | None = None
    name: str = "app_faults"
    rate_hz: float = 100.0
    played: list[tuple[float, Fault]] = field(default_factory=list)

    def __post_init__(self) -> None:
        self._pending = sorted((f for f in self.faults if f.kind in APP_KINDS),
                               key=lambda f: f.at_s)
        self._restarts: list[tuple[float, str]] = []  # (when [s], node) to start again
        self.restarted: list[tuple[float, str]] = []  # (when [s], node) started again

    def update(self, t_ns: int, scene: Scene) -> None:
        while self._restarts and round(self._restarts[0][0] * 1e9) <= t_ns:
            _, name = self._restarts.pop(0)
            self.executor.restart_node(name)
            self.restarted.append((t_ns / 1e9, name))
        while self._pending and round(self._pending[0].at_s * 1e9) <= t_ns:
            fault = self._pending.pop(0)
            if fault.kind is FaultKind.OPERATOR_ABORT:
                assert self.press_abort is not None
                self.press_abort()
            elif fault.kind is FaultKind.OPERATOR_SILENT:
                self.executor.stop_node("operator")
            else:
                self.executor.stop_node(fault.text("name"))
                if fault.duration_s is not None:
                    self._restarts = sorted([*self._restarts, (fault.end_s, fault.text("name"))])
            self.played.append((t_ns / 1e9, fault))


def judge_flight(faults: Sequence[Fault], failsafes: FcuFailsafes, truth: Trajectory,
                 arena: ArenaSpec, resting_height_m: float, crash: Crash | None,
                 skipped: Sequence[tuple[float, int, str]] = ()) -> list[dict[str, object]]:
    """The report's ``faults`` of a flight without the mission (navigate, precision
    landing): the FCU's failsafes, the pads not landed on and the end state only."""
    ended = end_state(truth, arena, resting_height_m, crash)
    return [judge_fault(f, [], failsafes.entered_s, ended, skipped, mission=False)
            for f in faults]
