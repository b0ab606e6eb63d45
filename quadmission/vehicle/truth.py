"""The vehicle's ground truth, in its output folder (never on the graph).

``quadmission vehicle --out DIR`` writes, when it ends (SIGINT or SIGTERM included):

- ``DIR/truth.npz``: the true trajectory (``t`` [s simulated], ``position`` [m, ENU],
  ``quaternion`` (w, x, y, z), ``velocity`` [m/s]) as :class:`sim.world.Trajectory`.
- ``DIR/vehicle.json`` (:data:`VEHICLE_JSON`): ``host_ns_at_sim_zero`` (the host clock the
  vehicle's stamps are on, at simulated time 0: a companion time ``T`` ns is simulated
  time ``T - host_ns_at_sim_zero``), ``touchdowns`` (the FCU's land detector going to
  landed, with the true position), ``nav_states`` and ``failsafes`` (the FCU's, with
  their simulated time), ``setpoints`` (the offboard stream as the FCU took it: count,
  largest gap, gaps over 0.5 s), ``vision`` (the age of the external vision the FCU fused:
  count, p50, p99, largest), ``crash``, how far it fell behind real time (``behind``), the
  arena, seed, rtf and the run's figures.
- ``DIR/arena.yaml``: the arena flown.

:class:`FcuWatch` is the world part that notes the FCU's changes as they happen;
:func:`load_truth` reads the folder back for the evaluation.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sim.fcu.firmware import ConsumedVision, Firmware
from sim.world import Scene, Trajectory

__all__ = ["TOUCHDOWN_SAID", "TRUTH_NPZ", "VEHICLE_JSON", "FcuWatch", "VehicleTruth", "load_truth",
           "setpoint_figures", "vision_figures", "write_trajectory"]

#: a gap in the offboard stream worth counting [s]: the issue's bound (PX4 needs 2 Hz)
SETPOINT_GAP_S = 0.5

TRUTH_NPZ = "truth.npz"
VEHICLE_JSON = "vehicle.json"
TOUCHDOWN_SAID = "touchdown at"  # what the vehicle says (its log) as its FCU detects landed


@dataclass
class FcuWatch:
    """A world part: the FCU's navigation state, failsafes and touchdowns (its land
    detector's ``landed`` rising) as they change, each said once through ``say``."""

    firmware: Firmware
    say: Callable[[str], None] = lambda _line: None
    name: str = "fcu_watch"
    rate_hz: float = 50.0
    nav_states: list[dict[str, Any]] = field(default_factory=list)
    failsafes: list[dict[str, Any]] = field(default_factory=list)
    touchdowns: list[dict[str, Any]] = field(default_factory=list)
    setpoint_gaps_s: list[float] = field(default_factory=list)
    """Gaps between the offboard heartbeats (``/fmu/in/offboard_control_mode``) the FCU
    took while in OFFBOARD [s, at this part's rate]: PX4 drops offboard after
    ``COM_OF_LOSS_T`` of silence."""
    vision_ages_s: list[float] = field(default_factory=list)
    """The age of each external-vision sample as the FCU's estimator fused it [s]: its
    FCU time at the fusion less the sample's ``timestamp_sample`` (the companion's stamp,
    put on the FCU's clock by its time sync)."""
    _nav: str | None = None
    _heartbeat_us: int | None = None
    _heartbeat_s: float | None = None
    _failsafe: bool = False
    _landed: bool | None = None  # None until the land detector has said (at boot)

    def __post_init__(self) -> None:
        self.firmware.vision_observers.append(self._on_vision)

    def _on_vision(self, sample: ConsumedVision) -> None:
        if sample.timestamp_sample_us:  # 0: unstamped, taken as "now" by the FCU: no age
            self.vision_ages_s.append((sample.consumed_us - sample.timestamp_sample_us) / 1e6)

    def update(self, t_ns: int, scene: Scene) -> None:
        t_s = round(t_ns / 1e9, 3)
        status = self.firmware.status
        if status is not None:
            nav = status.nav_state.name
            if nav != self._nav:
                self.nav_states.append({"t_s": t_s, "nav_state": nav})
                self.say(f"FCU nav_state {nav} at {t_s:.2f} s")
                self._nav = nav
            if status.failsafe and not self._failsafe:
                reason = status.failsafe_reason.name
                self.failsafes.append({"t_s": t_s, "nav_state": nav, "reason": reason})
                self.say(f"FCU FAILSAFE at {t_s:.2f} s: {reason}, nav_state {nav}")
            self._failsafe = bool(status.failsafe)
            beat = self.firmware.offboard_heartbeat_us
            if beat != self._heartbeat_us:
                if nav == "OFFBOARD" and self._heartbeat_s is not None:
                    self.setpoint_gaps_s.append(round(t_ns / 1e9 - self._heartbeat_s, 3))
                self._heartbeat_us, self._heartbeat_s = beat, t_ns / 1e9
            elif nav != "OFFBOARD":
                self._heartbeat_s = None  # a gap counts from a heartbeat in OFFBOARD
        land = self.firmware.land
        if land is None:
            return
        landed = bool(land.landed)
        if landed and self._landed is False:  # not its first word: it stood on its pad
            x, y, z = (float(v) for v in scene.views.quad_qpos[:3])
            self.touchdowns.append({"t_s": t_s, "position_m": [round(x, 4), round(y, 4),
                                                               round(z, 4)]})
            self.say(f"{TOUCHDOWN_SAID} {t_s:.2f} s at ({x:.3f}, {y:.3f}) m")
        self._landed = landed


def setpoint_figures(gaps_s: list[float]) -> dict[str, Any]:
    """The offboard stream's figures from its gaps [s]."""
    return {"heartbeats": len(gaps_s), "max_gap_s": max(gaps_s, default=None),
            f"gaps_over_{SETPOINT_GAP_S:g}_s": sum(g > SETPOINT_GAP_S for g in gaps_s),
            "p99_gap_s": float(np.percentile(gaps_s, 99)) if gaps_s else None}


def vision_figures(ages_s: list[float]) -> dict[str, Any]:
    """The fused vision's figures from its ages [s]: count, p50, p99 and largest [ms]."""
    def ms(q: float) -> float | None:
        return round(float(np.percentile(ages_s, q)) * 1e3, 2) if ages_s else None
    return {"fused": len(ages_s), "age_p50_ms": ms(50), "age_p99_ms": ms(99),
            "age_max_ms": ms(100)}


def write_trajectory(out: Path, trajectory: Trajectory) -> Path:
    """``out/truth.npz``."""
    path = out / TRUTH_NPZ
    np.savez_compressed(path, t=trajectory.t, position=trajectory.position,
                        quaternion=trajectory.quaternion, velocity=trajectory.velocity)
    return path


@dataclass(frozen=True)
class VehicleTruth:
    """What a vehicle run wrote (:func:`load_truth`)."""

    trajectory: Trajectory
    summary: dict[str, Any]

    @property
    def host_ns_at_sim_zero(self) -> int:
        return int(self.summary["host_ns_at_sim_zero"])

    def sim_time_s(self, host_ns: int) -> float:
        """The simulated time [s] of a companion stamp ``host_ns`` [ns, host clock]."""
        return (host_ns - self.host_ns_at_sim_zero) / 1e9


def load_truth(out: Path) -> VehicleTruth:
    """The trajectory and ``vehicle.json`` of the vehicle run that wrote ``out``."""
    with np.load(out / TRUTH_NPZ) as data:
        trajectory = Trajectory(data["t"], data["position"], data["quaternion"],
                                data["velocity"])
    summary = json.loads((out / VEHICLE_JSON).read_text(encoding="utf-8"))
    return VehicleTruth(trajectory, summary)
