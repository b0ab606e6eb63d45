"""``quadmission vehicle``: the simulator alone, as a vehicle on the wall clock.

It stands on the ROS 2 graph where a PX4 v1.17 behind its uXRCE-DDS agent, the camera
drivers and a VIO would stand, and nothing else is there: the agent's ``/fmu/out/*`` and
``/fmu/in/*`` (v1.17 names, px4_msgs types, the agent's QoS, PX4 microseconds on the
FCU's own boot clock, across the link model), ``/camera/down/image_raw`` and
``camera_info``, ``/camera/depth/points``, and the VIO's ``/sim/vision/pose``; no
``/clock``, no lockstep, no modelled XRCE session topics (PX4's agent syncs the clocks
inside its session and reports on ``/fmu/out/timesync_status``).

Its clocks: the physics, the FCU and the cameras run in simulated time, paced to ``rtf``
x the host's monotonic clock (:class:`Pacer`); the stamps a camera driver or a VIO on the
vehicle's computer would write (``header.stamp``), and the agent's answers to the FCU's
time sync, read the host's clock: simulated time plus the host's ``time.time_ns()`` at
simulated time 0 (``host_ns_at_sim_zero`` in ``vehicle.json``). At ``rtf`` 1 that is
the host's clock while the vehicle keeps up; when it falls behind, its stamps lag the
host's clock by as much, as a late sensor's would, and :class:`~quadmission.vehicle.lag.
LagMonitor` says so (how far, how long, how often). At another ``rtf`` its clocks run
that many times faster than the host's: a companion on the host's clock flies it only at
1 (its time sync sees the rate as a skew).

Ground truth (the trajectory, touchdowns, the FCU's failsafes, a crash) goes to the
output folder only (:mod:`quadmission.vehicle.truth`), written when the run ends:
SIGINT or SIGTERM, the time limit or a crash.
"""

from __future__ import annotations

import json
import math
import signal
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from quadmission.errors import OptionsError
from quadmission.scenarios.mission.launch import mission_sitl
from quadmission.scenarios.options import ScenarioOptions
from quadmission.vehicle.lag import LagMonitor
from quadmission.vehicle.truth import (
    VEHICLE_JSON,
    FcuWatch,
    setpoint_figures,
    vision_figures,
    write_trajectory,
)
from runtime.executor import DEFAULT_CONFIG_DIR, DeterministicExecutor
from sim.arena import Lighting
from sim.fault_spec import Fault
from sim.faults import SIM_KINDS
from sim.render import SceneRenderer
from sim.sensors import sensor_parts
from sim.world import Scene, StopWhen, WorldResult, WorldStatus

__all__ = ["EXIT_CRASHED", "Pacer", "VehicleOptions", "VehicleOutcome", "run_vehicle"]

EXIT_CRASHED = 1
_PACE_HZ = 1000.0  # pacing and taking what arrived, per simulated second (at most)
_DAY_S = 86400.0
#: behind real time, what arrived is taken at most this often [ns simulated] (keeping up, at
#: every pacing step: the wait returns on arrival). An rcl wait costs ~0.3 ms: at every
#: step it was a third of the vehicle's main thread, the time it needs to catch up
_TAKE_BEHIND_NS = 5_000_000


@dataclass(frozen=True)
class VehicleOptions:
    """What ``quadmission vehicle`` takes."""

    out: Path
    seed: int = 0
    arena: Path | None = None
    random_arena: bool = False
    lighting: Lighting | None = None
    faults: tuple[Fault, ...] = ()
    rtf: float = 1.0
    domain_id: int = 0
    loopback_only: bool = True
    duration_s: float = _DAY_S
    config_dir: Path | None = None

    def __post_init__(self) -> None:
        if not 0.0 < self.rtf < math.inf:
            raise OptionsError(f"--rtf {self.rtf:g}: a vehicle on the wall clock needs a "
                               "positive, finite rate")
        if not 0 <= self.domain_id <= 232:
            raise OptionsError(f"--domain-id {self.domain_id} is outside 0..232")
        other = sorted({f.kind.value for f in self.faults if f.kind not in SIM_KINDS})
        if other:
            raise OptionsError(f"--fault {', '.join(other)}: not a fault of the vehicle (it "
                               f"plays the simulator's: "
                               f"{', '.join(sorted(k.value for k in SIM_KINDS))})")


    def argv(self) -> list[str]:
        """``quadmission vehicle``'s arguments for these options."""
        return [
            "--out", str(self.out), "--seed", str(self.seed),
            *(["--arena", str(self.arena)] if self.arena else []),
            *(["--random-arena"] if self.random_arena else []),
            *(["--lighting", self.lighting.value] if self.lighting else []),
            *(a for f in self.faults for a in ("--fault", f.spec())),
            "--rtf", repr(self.rtf), "--domain-id", str(self.domain_id),
            *([] if self.loopback_only else ["--network"]),
            *([] if self.duration_s == _DAY_S else ["--duration", repr(self.duration_s)]),
            *(["--config-dir", str(self.config_dir)] if self.config_dir else [])]


@dataclass(frozen=True)
class VehicleOutcome:
    exit_code: int
    reason: str
    summary: dict[str, Any]


@dataclass
class Pacer:
    """The first world part, at up to :data:`_PACE_HZ`: takes what arrived on the
    transport, then waits (on the transport, so arrivals are taken as they come) until
    the host's monotonic clock has reached simulated time / ``rtf``; behind, it goes on at
    once and tells the lag monitor. Its first update anchors the run to the host: simulated
    time ``t`` is then due at ``host0 + t / rtf``, and ``anchor`` is called with the host's
    clock [ns] at simulated time 0 (before any other part of that tick publishes)."""

    wait: Callable[[float], object]
    dispatch: Callable[[], int]
    rtf: float
    rate_hz: float
    monitor: LagMonitor
    say: Callable[[str], None]
    stopped: Callable[[], bool]
    anchor: Callable[[int], None]
    name: str = "wall_clock_pacer"
    host0: float | None = None  # host monotonic time of simulated time 0 [s]
    taken: int = 0  # samples handed to the nodes
    _taken_ns: int = -_TAKE_BEHIND_NS  # simulated time of the last take

    def update(self, t_ns: int, scene: Scene) -> None:
        if self.host0 is None:
            self.host0 = time.monotonic() - t_ns / 1e9 / self.rtf
            self.anchor(time.time_ns() - t_ns)
        target = self.host0 + t_ns / 1e9 / self.rtf
        if target > time.monotonic() or t_ns - self._taken_ns >= _TAKE_BEHIND_NS:
            self.taken += self.dispatch()  # behind: every _TAKE_BEHIND_NS only (it costs)
            self._taken_ns = t_ns
        while not self.stopped():
            ahead = target - time.monotonic()
            if ahead <= 0.0:
                break
            self.wait(ahead)
            self.taken += self.dispatch()
        now = time.monotonic()
        line = self.monitor.update(now - self.host0, now - target)
        if line is not None:
            self.say(f"{line} at {t_ns / 1e9:.3f} s simulated")

    def host_s(self) -> float:
        """Host seconds since simulated time 0."""
        return 0.0 if self.host0 is None else time.monotonic() - self.host0


def _tick_hz(physics_hz: int) -> float:
    """The fastest rate up to :data:`_PACE_HZ` that divides the physics rate."""
    return physics_hz / math.ceil(physics_hz / _PACE_HZ)


def run_vehicle(options: VehicleOptions, say: Callable[[str], None]) -> VehicleOutcome:
    """Run the vehicle until SIGINT/SIGTERM, ``duration_s`` or a crash; write the truth."""
    from runtime.ros2.config import Ros2Config
    from runtime.ros2.transport import Ros2Transport

    options.out.mkdir(parents=True, exist_ok=True)
    arena = ScenarioOptions(out=options.out, seed=options.seed, arena=options.arena,
                            random_arena=options.random_arena,
                            lighting=options.lighting).load_arena()  # also OUT/arena.yaml
    transport = Ros2Transport(Ros2Config(options.domain_id, options.loopback_only),
                              name="vehicle", use_sim_time=False)
    stop: list[str] = []  # the signal that stops the run, once it came

    def on_signal(signum: int, _frame: Any) -> None:
        stop.append(signal.Signals(signum).name)
        transport.wake()

    previous = {sig: signal.signal(sig, on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
    ex = DeterministicExecutor(transport=transport, config_dir=options.config_dir
                               or DEFAULT_CONFIG_DIR)
    try:
        simulation = mission_sitl(ex, arena, seed=options.seed, faults=options.faults,
                                  vehicle=True)
        sitl = simulation.sitl
        watch = FcuWatch(sitl.firmware, say)
        monitor = LagMonitor()
        with SceneRenderer(sitl.scene.model) as renderer:
            sitl.extra_parts.extend(sensor_parts(simulation.sensors, renderer, sitl.scene,
                                                 seed=options.seed))
            sitl.extra_parts.append(watch)
            host_zero = [0]  # the host's clock at simulated time 0 [ns], once anchored

            def anchor(host_zero_ns: int) -> None:
                """The stamps' clock and the agent's: the host's."""
                host_zero[0] = host_zero_ns
                simulation.sensors.stamp_offset_ns = host_zero_ns
                sitl.vision.node.stamp_offset_ns = host_zero_ns
                sitl.agent.clock_offset_ns += host_zero_ns

            pacer = Pacer(transport.wait, transport.dispatch, options.rtf,
                          _tick_hz(sitl.scene.physics_hz), monitor, say,
                          lambda: bool(stop), anchor)
            sitl.first_parts.insert(0, pacer)
            say(f"vehicle up on ROS domain {options.domain_id}: arena {arena.name}, seed "
                f"{options.seed}, rtf {options.rtf:g}; ground truth to {options.out}")
            result = sitl.run(options.duration_s, stop=StopWhen(lambda: bool(stop)))
        host_s = pacer.host_s()
        host_zero_ns = host_zero[0]
        outcome = _outcome(result, stop[0] if stop else "")
        summary = _summary(options, arena.name, host_zero_ns, result, host_s, monitor, watch,
                           pacer.taken, outcome)
        write_trajectory(options.out, result.trajectory)
        (options.out / VEHICLE_JSON).write_text(json.dumps(summary, indent=2) + "\n",
                                                encoding="utf-8")
        behind = summary["behind"]
        say(f"ran {summary['sim_time_s']:.3f} s simulated in {host_s:.3f} s (real-time "
            f"factor {summary['rtf_achieved']}); fell behind by over "
            f"{monitor.threshold_s * 1e3:.0f} ms {behind['episodes']} times, at most "
            f"{behind['max_lag_s'] * 1e3:.0f} ms, {behind['behind_s']:.1f} s in all")
        say(f"{outcome.reason}; ground truth in {options.out}")
        return VehicleOutcome(outcome.exit_code, outcome.reason, summary)
    finally:
        for node in reversed(list(ex.context.nodes)):
            node.destroy_node()
        transport.close()
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def _outcome(result: WorldResult, signal_name: str) -> VehicleOutcome:
    if result.crash is not None:
        return VehicleOutcome(EXIT_CRASHED, f"CRASH: {result.crash.reason} at "
                                            f"{result.crash.t_s:.1f} s", {})
    if result.status is WorldStatus.STOPPED:
        return VehicleOutcome(0, f"stopped by {signal_name or 'a signal'} at "
                                 f"{result.sim_time_s:.1f} s", {})
    return VehicleOutcome(0, f"time limit: {result.sim_time_s:g} s of simulated time", {})


def _summary(options: VehicleOptions, arena: str, host_zero_ns: int, result: WorldResult,
             host_s: float, monitor: LagMonitor, watch: FcuWatch, taken: int,
             outcome: VehicleOutcome) -> dict[str, Any]:
    crash = result.crash
    return {
        "arena": arena, "seed": options.seed, "random_arena": options.random_arena,
        "lighting": None if options.lighting is None else options.lighting.value,
        "faults": [f.spec() for f in options.faults], "rtf": options.rtf,
        "domain_id": options.domain_id,
        "host_ns_at_sim_zero": host_zero_ns,
        "sim_time_s": round(result.sim_time_s, 3), "wall_time_s": round(host_s, 3),
        "rtf_achieved": round(result.sim_time_s / host_s, 3) if host_s > 0 else None,
        "cpu_time_s": round(result.cpu_time_s, 3),
        "samples_taken": taken,
        "behind": monitor.summary(host_s),
        "setpoints": setpoint_figures(watch.setpoint_gaps_s),
        "vision": vision_figures(watch.vision_ages_s),
        "touchdowns": watch.touchdowns, "failsafes": watch.failsafes,
        "nav_states": watch.nav_states,
        "crash": None if crash is None else {
            "reason": crash.reason, "t_s": round(crash.t_s, 3),
            "position_m": [round(float(v), 3) for v in crash.position]},
        "exit_code": outcome.exit_code, "reason": outcome.reason,
    }
