"""The firmware's shared tuning comes from config/fcu_firmware.yaml and fcu_land_detector.yaml."""

from __future__ import annotations

from dataclasses import replace

import pytest

from runtime.errors import ParameterError
from runtime.parameters import load_parameters
from sim.fcu.firmware import FIRMWARE_NODE_NAME, FirmwareConfig, FirmwareParams
from sim.fcu.land_detector import LAND_DETECTOR_NODE_NAME, LandDetectorParams
from sim.fcu.sitl import build_sitl

FIRMWARE = load_parameters(FirmwareParams, FIRMWARE_NODE_NAME)


def test_the_imu_rate_and_the_land_detector_come_from_config() -> None:
    sitl = build_sitl()
    assert sitl.imu.rate_hz == FIRMWARE.imu_rate_hz
    cfg = sitl.firmware.config
    assert cfg.land_detector is not None and cfg.control is not None
    detector = sitl.firmware.land_detector
    assert detector.params == load_parameters(LandDetectorParams, LAND_DETECTOR_NODE_NAME)
    # the thrust thresholds are the control's and the airframe's, not a second copy
    assert detector.thrust_min == cfg.control.thrust_min_fraction
    assert detector.thrust_hover == pytest.approx(cfg.quad.hover_thrust / cfg.quad.max_motor_thrust)


def test_a_firmware_config_overrides_the_file() -> None:
    sitl = build_sitl(firmware=FirmwareConfig(firmware=replace(FIRMWARE, imu_rate_hz=1000.0)))
    assert sitl.imu.rate_hz == 1000.0


def test_firmware_parameters_are_checked() -> None:
    with pytest.raises(ParameterError, match=r"^idle_thrust_fraction: 0\.5 is outside the allowed "
                                             r"range \[0, 0\.3\]"):
        replace(FIRMWARE, idle_thrust_fraction=0.5)
