"""ArUco marker textures (DICT_7X7_1000) for landing pads and ground robots.

A DICT_7X7_1000 marker is 9 x 9 modules: a 7 x 7 bit matrix inside a one-module black
border. Textures are drawn on an integer module grid (``px_per_module`` pixels per module)
so edges stay crisp, with a one-module white quiet zone around the marker that keeps its
black border detectable on any background.

Images are RGB ``uint8`` with row 0 at the top; when mapped on the top face of a box in
MuJoCo, the top row lies towards +y (north) and column 0 towards -x (west), so the marker
reads upright in a camera whose image up is north.
"""

from __future__ import annotations

import functools

import cv2
import numpy as np
import numpy.typing as npt

from runtime.errors import ParameterError
from sim.arena import PAD_MARKER_SIZE, PAD_SIZE, ROBOT_MARKER_SIZE, ROBOT_SIZE

ARUCO_DICTIONARY_ID = cv2.aruco.DICT_7X7_1000
MARKER_MODULES = 9  # 7 x 7 bits + a one-module black border on each side
QUIET_ZONE_MODULES = 1  # white margin around the marker, in modules
DEFAULT_PX_PER_MODULE = 16

Rgb = tuple[int, int, int]
PAD_RGB: Rgb = (135, 206, 250)  # light blue ("light sky blue")
ROBOT_TOP_RGB: Rgb = (255, 255, 255)
QUIET_ZONE_RGB: Rgb = (255, 255, 255)

Image = npt.NDArray[np.uint8]


@functools.cache
def aruco_dictionary() -> cv2.aruco.Dictionary:
    """The contest dictionary, DICT_7X7_1000 (IDs 0-999)."""
    return cv2.aruco.getPredefinedDictionary(ARUCO_DICTIONARY_ID)


def marker_image(marker_id: int, px_per_module: int = DEFAULT_PX_PER_MODULE) -> Image:
    """The bare marker (black border included, no quiet zone) as a square grey image."""
    if px_per_module < 1:
        raise ParameterError(f"px_per_module: {px_per_module} must be >= 1")
    size = aruco_dictionary().bytesList.shape[0]
    if not 0 <= marker_id < size:
        raise ParameterError(f"marker_id: {marker_id} is not in DICT_7X7_1000 (0-{size - 1})")
    side = MARKER_MODULES * px_per_module
    image = cv2.aruco.generateImageMarker(aruco_dictionary(), marker_id, side, borderBits=1)
    return np.asarray(image, dtype=np.uint8)


def marker_tile(
    marker_id: int,
    tile_size: float,
    marker_size: float,
    background: Rgb,
    px_per_module: int = DEFAULT_PX_PER_MODULE,
) -> Image:
    """A ``tile_size`` metre square of ``background`` with a ``marker_size`` marker centred on it.

    The marker keeps a one-module white quiet zone, so the tile must be at least
    ``(9 + 2) / 9 * marker_size`` wide.
    """
    modules_needed = MARKER_MODULES + 2 * QUIET_ZONE_MODULES
    if tile_size * MARKER_MODULES < marker_size * modules_needed - 1e-9:
        raise ParameterError(
            f"tile_size: {tile_size} m cannot hold a {marker_size} m marker with its quiet zone"
        )
    marker = marker_image(marker_id, px_per_module)
    side_px = round(tile_size / marker_size * MARKER_MODULES * px_per_module)
    tile = np.empty((side_px, side_px, 3), dtype=np.uint8)
    tile[:] = background
    quiet_px = modules_needed * px_per_module
    start = (side_px - quiet_px) // 2
    tile[start : start + quiet_px, start : start + quiet_px] = QUIET_ZONE_RGB
    start += QUIET_ZONE_MODULES * px_per_module
    tile[start : start + marker.shape[0], start : start + marker.shape[1]] = marker[..., None]
    return tile


def pad_texture(pad_id: int, px_per_module: int = DEFAULT_PX_PER_MODULE) -> Image:
    """Landing pad: a 1 m light-blue square with the 0.5 m marker ``pad_id`` in the centre."""
    return marker_tile(pad_id, PAD_SIZE, PAD_MARKER_SIZE, PAD_RGB, px_per_module)


def robot_texture(marker_id: int, px_per_module: int = DEFAULT_PX_PER_MODULE) -> Image:
    """Top of a ground robot: white, with a 0.4 m marker ``marker_id`` in the centre."""
    return marker_tile(marker_id, ROBOT_SIZE[0], ROBOT_MARKER_SIZE, ROBOT_TOP_RGB, px_per_module)


def encode_png(image: Image) -> bytes:
    """PNG bytes of an RGB (or grey) ``uint8`` image."""
    bgr = cv2.cvtColor(image, cv2.COLOR_RGB2BGR) if image.ndim == 3 else image
    ok, buffer = cv2.imencode(".png", bgr)
    if not ok:
        raise ParameterError(f"image: cannot encode a {image.shape} {image.dtype} array as PNG")
    return bytes(buffer.tobytes())


def detect_markers(image: Image) -> dict[int, npt.NDArray[np.float32]]:
    """Decode DICT_7X7_1000 markers in an RGB or grey image: ``{id: corners (4, 2) px}``.

    Corners run clockwise from the marker's top-left, as OpenCV returns them. This is the
    ground-truth check the sim tests use; the mission's scanner lives in ``perception/``.
    """
    grey = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY) if image.ndim == 3 else image
    detector = cv2.aruco.ArucoDetector(aruco_dictionary(), cv2.aruco.DetectorParameters())
    corners, ids, _ = detector.detectMarkers(grey)
    if ids is None:
        return {}
    return {
        int(i): np.asarray(c, dtype=np.float32).reshape(4, 2)
        for i, c in zip(ids.ravel(), corners, strict=True)
    }
