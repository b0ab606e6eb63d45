"""Record the FCU's hot math during the square flight: inputs and the outputs they gave.

    MUJOCO_GL=egl python tests/sim/fcu/record_fcu_math.py

Writes ``tests/sim/fcu/data/fcu_math.npz``, which ``test_fcu_math_recorded.py`` replays
through the current implementation (results must stay within 1e-6). The file was
recorded from the numpy implementation (before the float rewrite), so it pins the
behaviour the rewrite had to keep; re-recording it would only pin the current code. (The
hooks wrap the controllers' public ``update`` methods, which the firmware called then; it
now calls their float paths, ``update_floats`` and ``update_quat``, so the recording is
reproduced at the commit it was made from, not at this one.)

Stateful parts (position controller, rate controller, estimator) are recorded call by
call from boot until ``STATEFUL_S`` after arming, so a fresh instance replays them
exactly; stateless parts (attitude controller, mixer) every ``STATELESS_EVERY``-th call
over the whole flight, then ``EXTREME_CALLS`` seeded extreme inputs each (the flight never
saturates the mixer).
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np

import sim.fcu.firmware as firmware_module
from sim.fcu.control import (
    AttitudeController,
    Mixer,
    PositionController,
    RateController,
    mix_with_desaturation,
)
from sim.fcu.estimator import Estimator

OUT = Path(__file__).resolve().parent / "data" / "fcu_math.npz"
STATEFUL_S = 5.0  # s after arming
STATELESS_EVERY = 7
EXTREME_CALLS = 300  # seeded extreme inputs for the stateless parts
EST_OUTPUT_EVERY = 5  # estimator outputs kept after every 5th prediction (and every fusion)


def _state_row(state: Any) -> list[float]:
    return [*state.position_ned, *state.velocity_ned, *state.q, *state.angular_velocity_frd]


def _setpoint_row(sp: Any) -> list[float]:
    return [*sp.position, *sp.velocity, *sp.acceleration, *sp.jerk, sp.yaw, sp.yawspeed]


def _estimate_row(est: Any) -> list[float]:
    s = est.state
    return [float(est.time_us), *_state_row(s), *est.position_variance_ned,
            *est.velocity_variance_ned, *est.accel_bias_frd, *est.gyro_bias_frd,
            float(est.position_valid), float(est.dead_reckoning_time_us), float(est.vision_fused),
            float(est.vision_rejected)]


def record() -> dict[str, np.ndarray]:
    rows: dict[str, list[list[float]]] = {k: [] for k in (
        "pos_in", "pos_out", "rate_in", "rate_out", "att_in", "att_out", "mix_in", "mix_out",
        "est_in", "est_out")}
    clock: dict[str, Any] = {"armed_us": None, "now_us": 0, "att_n": 0, "mix_n": 0, "est_n": 0}

    def stateful_open() -> bool:
        armed = clock["armed_us"]
        return armed is None or clock["now_us"] - armed <= STATEFUL_S * 1e6

    pos_update, pos_reset = PositionController.update, PositionController.reset
    rate_update, rate_reset = RateController.update, RateController.reset
    rate_sat = RateController.set_saturation_flags
    att_update = AttitudeController.update
    est_predict, est_fuse, est_reset = Estimator.predict, Estimator.fuse_vision, Estimator.reset
    mixer_mix = Mixer.mix
    nan = math.nan

    # op codes: 0 = update/predict, 1 = reset, 2 = set_saturation / fuse_vision
    def p_update(self: Any, state: Any, sp: Any, dt_us: int) -> Any:
        out = pos_update(self, state, sp, dt_us)
        if stateful_open():
            rows["pos_in"].append([0.0, *_state_row(state), *_setpoint_row(sp), float(dt_us)])
            rows["pos_out"].append([*out.velocity_setpoint_ned, *out.acceleration_setpoint_ned,
                                    *out.thrust_ned, out.collective_thrust,
                                    *out.attitude_setpoint, out.yawspeed_feedforward])
        return out

    def p_reset(self: Any) -> None:
        pos_reset(self)
        if stateful_open() and hasattr(self, "_g"):
            rows["pos_in"].append([1.0] + [nan] * 28)
            rows["pos_out"].append([nan] * 15)

    def r_update(self: Any, rate: Any, rate_sp: Any, dt_us: int, landed: bool = False) -> Any:
        out = rate_update(self, rate, rate_sp, dt_us, landed)
        if stateful_open():
            rows["rate_in"].append([0.0, *rate, *rate_sp, float(dt_us), float(landed)])
            rows["rate_out"].append([*out])
        return out

    def r_reset(self: Any) -> None:
        rate_reset(self)
        if stateful_open() and hasattr(self, "_gains"):
            rows["rate_in"].append([1.0] + [nan] * 8)
            rows["rate_out"].append([nan] * 3)

    def r_sat(self: Any, flags: Any) -> None:
        rate_sat(self, flags)
        if stateful_open():
            rows["rate_in"].append([2.0, *flags, nan, nan])
            rows["rate_out"].append([nan] * 3)

    def a_update(self: Any, q: Any, q_sp: Any, ff: float = nan) -> Any:
        out = att_update(self, q, q_sp, ff)
        clock["att_n"] += 1
        if clock["att_n"] % STATELESS_EVERY == 0:
            rows["att_in"].append([*q, *q_sp, ff])
            rows["att_out"].append([*out])
        return out

    def m(self: Any, collective: float, torque: Any) -> None:
        mixer_mix(self, collective, torque)
        clock["mix_n"] += 1
        saturated = bool(self.out[5:].any())
        if clock["mix_n"] % (3 if saturated else STATELESS_EVERY) == 0:
            rows["mix_in"].append([collective, *torque])
            rows["mix_out"].append(self.out.tolist())

    def e_predict(self: Any, time_us: int, accel: Any, gyro: Any) -> None:
        est_predict(self, time_us, accel, gyro)
        clock["now_us"] = time_us
        if stateful_open():
            rows["est_in"].append([0.0, float(time_us), *accel, *gyro] + [nan] * 6)
            clock["est_n"] += 1
            keep = clock["est_n"] % EST_OUTPUT_EVERY == 0
            rows["est_out"].append(_estimate_row(self.output()) if keep else [nan] * 30)

    def e_fuse(self: Any, sample: Any) -> bool:
        ok = est_fuse(self, sample)
        if stateful_open():
            q = sample.q if sample.q is not None else [nan] * 4
            rows["est_in"].append([2.0, float(sample.sample_time_us), *sample.position_ned,
                                   *q, sample.position_variance, nan, nan, nan, float(ok)])
            rows["est_out"].append(_estimate_row(self.output()))
        return ok

    def e_reset(self: Any, time_us: int, position_ned: Any = (0.0, 0.0, 0.0),
                q: Any = (1.0, 0.0, 0.0, 0.0)) -> None:
        est_reset(self, time_us, position_ned, q)
        if stateful_open() and hasattr(self, "_buf"):
            rows["est_in"].append([1.0, float(time_us), *position_ned, *q] + [nan] * 5)
            rows["est_out"].append(_estimate_row(self.output()))

    original_armed = firmware_module.Firmware.armed

    def armed(self: Any) -> bool:
        value = bool(original_armed.fget(self))  # type: ignore[union-attr]
        if value and clock["armed_us"] is None:
            clock["armed_us"] = clock["now_us"]
        return value

    PositionController.update, PositionController.reset = p_update, p_reset  # type: ignore
    RateController.update, RateController.reset = r_update, r_reset  # type: ignore
    RateController.set_saturation_flags = r_sat  # type: ignore
    AttitudeController.update = a_update  # type: ignore
    Estimator.predict, Estimator.fuse_vision, Estimator.reset = e_predict, e_fuse, e_reset  # type: ignore
    Mixer.mix = m  # type: ignore
    firmware_module.Firmware.armed = property(armed)  # type: ignore

    from quadmission.scenarios import ScenarioOptions
    from quadmission.scenarios.square.flight import square

    with tempfile.TemporaryDirectory() as tmp:
        report = square(ScenarioOptions(out=Path(tmp)))
    assert report["landed"], report["verdict"]
    # the flight never saturates the mixer nor turns far: add seeded extreme inputs
    rng = np.random.default_rng(8)
    config = firmware_module.FirmwareConfig().resolved()
    assert config.control is not None
    quad = config.quad
    for _ in range(EXTREME_CALLS):
        collective = float(rng.uniform(-0.1, 1.1) * 4 * quad.max_motor_thrust)
        torque = rng.normal(0.0, 0.3, 3) * rng.choice([0.01, 0.1, 1.0])
        out = mix_with_desaturation(quad, collective, torque)
        rows["mix_in"].append([collective, *torque])
        rows["mix_out"].append([*out.motor_thrusts, out.collective_thrust,
                                *out.saturated_positive, *out.saturated_negative])
    att = AttitudeController(config.control)
    for _ in range(EXTREME_CALLS):
        q, q_sp = rng.normal(size=4), rng.normal(size=4)
        ff = float(rng.choice([nan, rng.normal()]))
        rows["att_in"].append([*q, *q_sp, ff])
        rows["att_out"].append([*att_update(att, q, q_sp, ff)])
    commit = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                            cwd=Path(__file__).resolve().parent, check=True).stdout.strip()
    data = {k: np.asarray(v, dtype=np.float64) for k, v in rows.items()}
    data["recorded_at_commit"] = np.array(commit)
    return data


def main() -> int:
    data = record()
    OUT.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(OUT, **data)  # type: ignore[arg-type]
    for key, value in data.items():
        print(key, value.shape, file=sys.stderr)
    print(f"wrote {OUT} ({OUT.stat().st_size // 1024} kB)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
