"""PX4's multicopter land detector (``MulticopterLandDetector.cpp``), stage by stage.

Three stages, each a condition held through a hysteresis before its flag goes true; any
flag drops at once when its condition fails (PX4's ``set_hysteresis_time_from(false, t)``),
with ``t = trigger_time_s / 3`` per stage (``LNDMC_TRIG_TIME``, default 1 s):

1. ``ground_contact``: thrust low (at or below ``min + 0.3 (hover - min)``, of the throttle
   range), no vertical movement (``|vz| <= z_vel_max``, widened 2.5x once maybe landed),
   no horizontal movement (``|v_xy| <= xy_vel_max``) and, if the vehicle is under
   climb-rate control, a commanded descent (``vz_setpoint > descent_vz_threshold``, NED)
   until maybe landed.
2. ``maybe_landed``: ``ground_contact`` (the hysteresis state) and thrust minimal (at or
   below ``min + 0.1 (hover - min)``), not in free fall, roll/pitch rate below ``rot_max``
   (widened 2.5x once maybe landed).
3. ``landed``: ``maybe_landed`` held once more (the position controller idles the motors
   once maybe landed, which keeps the thrust criterion true).

Disarmed, all three are true (PX4: a disarmed vehicle is on the ground). ``freefall``:
specific-force norm below ``freefall_acc_threshold`` (``LNDMC_FFALL_THR``, 2 m/s^2)
held for ``freefall_trigger_time_s`` (``LNDMC_FFALL_TTRI``, 0.3 s). Velocities are NED
[m/s]; ``vz > 0`` is descending. Without valid vertical velocity the vehicle counts as
moving vertically, so ground contact never holds; ``maybe_landed`` is then PX4's
fallback: minimal thrust and no rotation for more than ``min_thrust_landed_s`` (8 s,
``MulticopterLandDetector::_get_maybe_landed_state``), as after the position-loss
descent. Without valid horizontal velocity, horizontal movement counts as absent, as in
PX4.

Pure module, no runtime, no MuJoCo; the node converts :class:`LandDetectedData` to
``px4_msgs/VehicleLandDetected``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

from runtime.errors import ParameterError
from runtime.parameters import param, validate_parameters

__all__ = [
    "LAND_DETECTOR_NODE_NAME",
    "MIN_THRUST_LANDED_US",
    "Hysteresis",
    "LandDetectedData",
    "LandDetector",
    "LandDetectorInputs",
    "LandDetectorParams",
]

LAND_DETECTOR_NODE_NAME = "fcu_land_detector"
"""The land detector's section in its ROS 2 parameter file, ``config/fcu_land_detector.yaml``."""

_US_PER_S = 1_000_000
MIN_THRUST_LANDED_US = 8 * _US_PER_S
"""Without a vertical velocity: minimal thrust and no rotation longer than this is
landed (PX4's constant ``8_s``, not a parameter)."""


@dataclass(frozen=True, slots=True)
class LandDetectorParams:
    """PX4's ``LNDMC_*`` and ``LNDMC_FFALL_*`` parameters and the stage thresholds' factors.

    No defaults: the values live in ``config/fcu_land_detector.yaml`` alone (PX4's defaults,
    with PX4's names, are noted there), so code and config cannot disagree. The thrust range
    the thresholds scale (PX4's ``MPC_THR_MIN`` and ``MPC_THR_HOVER``) is no parameter of the
    detector: :class:`LandDetector` takes it from the controller and the airframe.
    """

    z_vel_max: float = param(unit="m/s", range=(0.0, 10.0))
    """``LNDMC_Z_VEL_MAX`` [m/s]: vertical speed below which the vehicle is not moving."""
    xy_vel_max: float = param(unit="m/s", range=(0.0, 10.0))
    """``LNDMC_XY_VEL_MAX`` [m/s]: horizontal speed allowed while landed."""
    rot_max_deg_s: float = param(unit="deg/s", range=(0.0, 1000.0))
    """``LNDMC_ROT_MAX`` [deg/s]: roll/pitch rate allowed while landed."""
    trigger_time_s: float = param(unit="s", range=(0.0, 10.0))
    """``LNDMC_TRIG_TIME`` [s]: total hysteresis, a third per stage."""
    freefall_acc_threshold: float = param(unit="m/s^2", range=(0.0, 10.0))
    """``LNDMC_FFALL_THR`` [m/s^2]: specific-force norm below which the vehicle falls."""
    freefall_trigger_time_s: float = param(unit="s", range=(0.0, 5.0))
    """``LNDMC_FFALL_TTRI`` [s]."""
    descent_vz_threshold: float = param(unit="m/s", range=(0.0, 10.0))
    """Commanded descent speed [m/s, NED down] above which the vehicle is ``in_descend``."""
    low_thrust_fraction: float = param(range=(0.0, 1.0))
    """Ground contact needs thrust at or below ``min + this * (hover - min)`` (PX4: 0.3)."""
    minimal_thrust_fraction: float = param(range=(0.0, 1.0))
    """Maybe landed needs thrust at or below ``min + this * (hover - min)`` (PX4: 0.1)."""
    z_vel_widening: float = param(range=(1.0, 10.0))
    """Factor on ``z_vel_max`` once maybe landed (PX4: 2.5)."""
    rotation_widening: float = param(range=(1.0, 10.0))
    """Factor on ``rot_max_deg_s`` once maybe landed (PX4: 2.5)."""

    def __post_init__(self) -> None:
        validate_parameters(self)

    @property
    def stage_time_us(self) -> int:
        """Hysteresis of each stage [us]."""
        return round(self.trigger_time_s * _US_PER_S / 3)


# The per-update records are named tuples: immutable, and built in one call at 50 Hz.


class LandDetectorInputs(NamedTuple):
    """One update's inputs: the FCU's own estimates and setpoints."""

    now_us: int
    armed: bool
    thrust: float
    """Collective thrust command, normalised [0..1] (PX4's throttle)."""
    vx: float = 0.0
    """Velocity north [m/s] (NED)."""
    vy: float = 0.0
    """Velocity east [m/s]."""
    vz: float = 0.0
    """Velocity down [m/s]: positive when descending."""
    v_xy_valid: bool = True
    v_z_valid: bool = True
    roll_rate: float = 0.0
    """Body roll rate [rad/s]."""
    pitch_rate: float = 0.0
    """Body pitch rate [rad/s]."""
    specific_force_norm: float = 9.80665
    """Norm of the accelerometer's specific force [m/s^2]: about g at rest, 0 in free fall."""
    climb_rate_control: bool = True
    """The vertical velocity is under closed-loop control (auto and offboard modes)."""
    vz_setpoint: float = math.nan
    """Commanded vertical velocity [m/s, NED down], NaN if none."""


class LandDetectedData(NamedTuple):
    """The fields of ``px4_msgs/VehicleLandDetected``."""

    timestamp_us: int
    freefall: bool
    ground_contact: bool
    maybe_landed: bool
    landed: bool
    in_ground_effect: bool
    in_descend: bool
    has_low_throttle: bool
    vertical_movement: bool
    horizontal_movement: bool
    rotational_movement: bool
    close_to_ground_or_skipped_check: bool
    at_rest: bool


class Hysteresis:
    """PX4's ``systemlib::Hysteresis``: a boolean that changes only after a request holds.

    ``update(requested, now_us)`` switches the state to ``requested`` once it has been
    requested continuously for the delay of that direction (``to_true_us`` or
    ``to_false_us``); a delay of 0 switches at once.
    """

    __slots__ = ("_pending_since_us", "_state", "to_false_us", "to_true_us")

    def __init__(self, initial: bool, to_true_us: int = 0, to_false_us: int = 0) -> None:
        self._state = initial
        self.to_true_us = to_true_us
        self.to_false_us = to_false_us
        self._pending_since_us: int | None = None

    @property
    def state(self) -> bool:
        return self._state

    def update(self, requested: bool, now_us: int) -> bool:
        """Fold in the requested state at ``now_us``; the state after."""
        if requested == self._state:
            self._pending_since_us = None
            return self._state
        if self._pending_since_us is None:
            self._pending_since_us = now_us
        delay = self.to_true_us if requested else self.to_false_us
        if now_us - self._pending_since_us >= delay:
            self._state = requested
            self._pending_since_us = None
        return self._state


class LandDetector:
    """Call :meth:`update` at a fixed rate (PX4: 50 Hz) with non-decreasing times."""

    def __init__(self, params: LandDetectorParams, *, thrust_min: float,
                 thrust_hover: float) -> None:
        """``thrust_min`` and ``thrust_hover``: PX4's ``MPC_THR_MIN`` and ``MPC_THR_HOVER``,
        collective thrust as a fraction of the maximum [0..1], the controller's floor and
        the airframe's hover thrust."""
        for key, value in (("thrust_min", thrust_min), ("thrust_hover", thrust_hover)):
            if not 0.0 <= value <= 1.0:
                raise ParameterError(f"{value!r} is outside [0, 1]", key=key)
        if not thrust_min < thrust_hover:
            raise ParameterError(
                f"{thrust_hover!r} must be above thrust_min = {thrust_min!r}",
                key="thrust_hover",
            )
        self.params = params
        self.thrust_min = thrust_min
        self.thrust_hover = thrust_hover
        stage = self.params.stage_time_us
        self._ground_contact = Hysteresis(True, to_true_us=stage)
        self._maybe_landed = Hysteresis(True, to_true_us=stage)
        self._landed = Hysteresis(True, to_true_us=stage)
        self._freefall = Hysteresis(
            False, to_true_us=round(self.params.freefall_trigger_time_s * _US_PER_S)
        )
        self._in_descend = False
        self._min_thrust_since_us: int | None = None
        # the parameters' derived thresholds, once (update runs at 50 Hz)
        span = thrust_hover - thrust_min
        self._low_thrust = thrust_min + span * params.low_thrust_fraction
        self._minimal_thrust = thrust_min + span * params.minimal_thrust_fraction
        self._rot_max_rad_s = math.radians(self.params.rot_max_deg_s)

    def update(self, inputs: LandDetectorInputs) -> LandDetectedData:
        """Fold in one update's inputs; the detector's flags after it."""
        p = self.params
        now = inputs.now_us
        maybe_landed_before = self._maybe_landed.state
        landed_before = self._landed.state

        freefall = self._freefall.update(inputs.specific_force_norm < p.freefall_acc_threshold, now)

        # stage 1: ground contact
        z_threshold = p.z_vel_max * (p.z_vel_widening if maybe_landed_before else 1.0)
        vertical_movement = not inputs.v_z_valid or abs(inputs.vz) > z_threshold
        horizontal_movement = inputs.v_xy_valid and math.hypot(inputs.vx, inputs.vy) > p.xy_vel_max
        has_low_throttle = inputs.thrust <= self._low_thrust
        if inputs.climb_rate_control:
            self._in_descend = (
                math.isfinite(inputs.vz_setpoint) and inputs.vz_setpoint > p.descent_vz_threshold
            )
        else:
            self._in_descend = False
        ground_contact_now = has_low_throttle
        if inputs.climb_rate_control and not maybe_landed_before and not landed_before:
            ground_contact_now = ground_contact_now and self._in_descend
        ground_contact_now = ground_contact_now and not horizontal_movement
        ground_contact_now = ground_contact_now and not vertical_movement
        if not inputs.armed:
            ground_contact_now = True
        ground_contact = self._ground_contact.update(ground_contact_now, now)

        # stage 2: maybe landed
        rot_threshold = self._rot_max_rad_s * (
            p.rotation_widening if maybe_landed_before else 1.0
        )
        rotational_movement = math.hypot(inputs.roll_rate, inputs.pitch_rate) > rot_threshold
        minimal_thrust = inputs.thrust <= self._minimal_thrust
        if not minimal_thrust:
            self._min_thrust_since_us = None
        elif self._min_thrust_since_us is None:
            self._min_thrust_since_us = now
        if inputs.v_z_valid:
            maybe_now = (minimal_thrust and not freefall and not rotational_movement
                         and ground_contact)
        else:  # PX4's fallback without a vertical velocity
            since = self._min_thrust_since_us
            maybe_now = (not freefall and not rotational_movement and since is not None
                         and now - since > MIN_THRUST_LANDED_US)
        if not inputs.armed:
            maybe_now = True
        maybe_landed = self._maybe_landed.update(maybe_now, now)

        # stage 3: landed
        landed = self._landed.update(maybe_landed if inputs.armed else True, now)

        return LandDetectedData(
            timestamp_us=now,
            freefall=freefall,
            ground_contact=ground_contact,
            maybe_landed=maybe_landed,
            landed=landed,
            in_ground_effect=self._in_descend and not horizontal_movement,
            in_descend=self._in_descend,
            has_low_throttle=has_low_throttle,
            vertical_movement=vertical_movement,
            horizontal_movement=horizontal_movement,
            rotational_movement=rotational_movement,
            close_to_ground_or_skipped_check=True,  # no distance sensor: check skipped
            at_rest=landed
            and not (vertical_movement or horizontal_movement or rotational_movement),
        )
