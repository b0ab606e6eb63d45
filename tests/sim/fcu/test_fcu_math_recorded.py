"""The FCU's hot math replays a recorded square flight within 1e-6 of the recording.

``data/fcu_math.npz`` holds the inputs the position, attitude and rate controllers, the
mixer and the estimator got during the square flight, and the outputs the numpy
implementation gave them (``record_fcu_math.py``, recorded before the float rewrite).
Each controller is rebuilt from the configured parameters and fed the same calls in order.
The estimator's rows are no longer replayed: its algorithm changed after the rewrite (the
tilt error and a body-fixed accelerometer bias estimated jointly), so the recording holds
what it gave then, not what it must give now; tests/sim/fcu/test_estimator.py tests it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sim.fcu.control import (
    AttitudeController,
    Mixer,
    PositionController,
    RateController,
    TrajectorySetpointData,
    VehicleState,
    mix_with_desaturation,
)
from sim.fcu.firmware import FirmwareConfig

TOL = 1e-6
DATA = Path(__file__).resolve().parent / "data" / "fcu_math.npz"


@pytest.fixture(scope="module")
def rec() -> dict[str, np.ndarray]:
    with np.load(DATA) as data:
        return {k: data[k] for k in data.files}


@pytest.fixture(scope="module")
def config() -> FirmwareConfig:
    return FirmwareConfig().resolved()


def _state(row: np.ndarray) -> VehicleState:
    return VehicleState(row[0:3], row[3:6], row[6:10], row[10:13])


def _close(got: list[float], want: np.ndarray, what: str) -> None:
    got_arr = np.asarray(got, dtype=np.float64)
    both_nan = np.isnan(got_arr) & np.isnan(want)
    err = np.where(both_nan, 0.0, np.abs(got_arr - want))
    assert not np.isnan(err).any() and err.max() <= TOL, (
        f"{what}: differs from the recording by {np.nanmax(err):.3g} (> {TOL})\n"
        f"got  {got_arr}\nwant {want}")


def test_the_recording_covers_the_branches(rec: dict[str, np.ndarray]) -> None:
    mix_out = rec["mix_out"]
    assert mix_out[:, 5:].any(), "no saturated mixer call recorded"
    assert (~mix_out[:, 5:].astype(bool)).all(axis=1).any(), "no unsaturated mixer call"
    est_ops = set(rec["est_in"][:, 0].tolist())
    assert {0.0, 1.0, 2.0} <= est_ops, "predict, reset and vision fusion must all be recorded"
    assert (rec["rate_in"][:, 8] == 1.0).any() and (rec["rate_in"][:, 8] == 0.0).any()


def test_position_controller_replays(rec: dict[str, np.ndarray], config: FirmwareConfig) -> None:
    assert config.control is not None
    ctrl = PositionController(config.control, config.quad)
    for i, (row, want) in enumerate(zip(rec["pos_in"], rec["pos_out"], strict=True)):
        if row[0] == 1.0:
            ctrl.reset()
            continue
        sp = TrajectorySetpointData(row[14:17], row[17:20], row[20:23], row[23:26],
                                    yaw=float(row[26]), yawspeed=float(row[27]))
        out = ctrl.update(_state(row[1:14]), sp, int(row[28]))
        _close([*out.velocity_setpoint_ned, *out.acceleration_setpoint_ned, *out.thrust_ned,
                out.collective_thrust, *out.attitude_setpoint, out.yawspeed_feedforward],
               want, f"position call {i}")


def test_attitude_controller_replays(rec: dict[str, np.ndarray], config: FirmwareConfig) -> None:
    assert config.control is not None
    ctrl = AttitudeController(config.control)
    for i, (row, want) in enumerate(zip(rec["att_in"], rec["att_out"], strict=True)):
        _close(list(ctrl.update(row[0:4], row[4:8], float(row[8]))), want, f"attitude call {i}")


def test_rate_controller_replays(rec: dict[str, np.ndarray], config: FirmwareConfig) -> None:
    """Both ways of giving it the mixer's saturation: flags (tests, API) and the firmware's
    1.0/0.0 buffer."""
    assert config.control is not None
    ctrl = RateController(config.control, config.quad)
    fast = RateController(config.control, config.quad)
    for i, (row, want) in enumerate(zip(rec["rate_in"], rec["rate_out"], strict=True)):
        if row[0] == 1.0:
            ctrl.reset()
            fast.reset()
        elif row[0] == 2.0:
            ctrl.set_saturation(row[1:4].astype(bool), row[4:7].astype(bool))
            fast.set_saturation_flags((row[1:7] != 0.0).astype(np.float64))
        else:
            for c in (ctrl, fast):
                out = c.update(row[1:4], row[4:7], int(row[7]), landed=bool(row[8]))
                _close(list(out), want, f"rate call {i}")


def test_mixer_replays(rec: dict[str, np.ndarray], config: FirmwareConfig) -> None:
    """The function and the firmware's reused-buffer :class:`Mixer`."""
    mixer = Mixer(config.quad)
    for i, (row, want) in enumerate(zip(rec["mix_in"], rec["mix_out"], strict=True)):
        out = mix_with_desaturation(config.quad, float(row[0]), row[1:4])
        _close([*out.motor_thrusts, out.collective_thrust, *out.saturated_positive,
                *out.saturated_negative], want, f"mixer call {i}")
        mixer.mix(float(row[0]), row[1:4])
        _close(mixer.out.tolist(), want, f"Mixer call {i}")
        _close([*mixer.motor_thrusts, *mixer.saturation_flags], want[[0, 1, 2, 3, 5, 6, 7, 8, 9,
                                                                        10]], f"Mixer call {i}")
