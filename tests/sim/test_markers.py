"""Marker textures: decodable, right sizes, light-blue pads with a white quiet zone."""

from __future__ import annotations

import numpy as np
import pytest

from runtime.errors import ParameterError
from sim.markers import (
    MARKER_MODULES,
    PAD_RGB,
    detect_markers,
    marker_tile,
    pad_texture,
    robot_texture,
)


@pytest.mark.parametrize("pad_id", [1, 5, 10])
def test_pad_texture_decodes_and_has_the_contest_layout(pad_id: int) -> None:
    px_per_module = 8
    texture = pad_texture(pad_id, px_per_module)
    side = 2 * MARKER_MODULES * px_per_module  # 1 m pad, 0.5 m marker
    assert texture.shape == (side, side, 3)
    assert list(detect_markers(texture)) == [pad_id]
    corners = detect_markers(texture)[pad_id]
    marker_px = np.ptp(corners[:, 0])
    assert marker_px == pytest.approx(side / 2, abs=2), "marker is half the pad"
    assert tuple(texture[0, 0]) == PAD_RGB
    quiet = side // 4 - px_per_module // 2  # inside the one-module quiet zone
    assert tuple(texture[quiet, quiet]) == (255, 255, 255)


def test_robot_texture_decodes() -> None:
    assert list(detect_markers(robot_texture(23))) == [23]


def test_marker_without_room_for_its_quiet_zone_is_refused() -> None:
    with pytest.raises(ParameterError, match="tile_size"):
        marker_tile(3, tile_size=0.5, marker_size=0.5, background=(0, 0, 0))
    with pytest.raises(ParameterError, match="marker_id"):
        pad_texture(1000)
