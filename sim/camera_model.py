"""The down camera's image sensor, applied to the rendered frame.

MuJoCo renders what the scene looks like under the arena's lighting preset; a camera
turns that light into numbers, and in the dark that is where markers are lost (seed 003
Table 1). :class:`CameraSensorModel` treats the rendered RGB value as the light reaching
each pixel and runs it through a sensor:

1. photo-electrons: ``e = value / 255 * electrons_per_ms * exposure_ms``, where
   ``electrons_per_ms`` is how much light the preset's scene really gives (a dark room
   gives ~100x less than a lit one; the render only dims it ~3.4x, for people to see);
2. optional motion blur: the image moves during the exposure by the vehicle's rates
   (:func:`motion_blur_px`), a line kernel of that length;
3. shot noise and read noise: ``e + sqrt(e + read_noise_e^2) * z``, z standard normal
   (the Gaussian limit of Poisson shot noise plus Gaussian read noise: the same mean and
   variance per pixel; see :data:`NOISE_POOL_FRAMES` for where z comes from);
4. gain (``gain`` x the full-well scale: ``full_well_e`` electrons fill 255 at gain 1);
5. 8-bit quantisation: round and clip to 0-255.

Exposure and gain are the preset's (``config/sim_camera_model.yaml``), as an auto-exposure
settles in that light: in ``light`` a short exposure at unit gain; in ``dark`` the longest
exposure the frame rate and blur allow and a high gain, so the picture is bright but
grainy. The noise comes from a generator seeded by the caller: same seed, same frames.
Pure: numpy, OpenCV and numba; no MuJoCo.

Cost: a 640x480 RGB frame is about 0.9 M pixels. Drawing 0.9 M Poisson samples takes
~50 ms and 0.9 M normals ~9 ms, which at 12 Hz would make the sensor the costliest part
of a mission. So z is read from a pool of standard normals drawn once per camera, at an
offset drawn per frame: every frame's noise is standard normal pixel by pixel, and two
frames share a pattern only if they draw the same offset (1 in 6 M at 640x480). Steps
3-5 are one compiled pass over the pixels (:func:`_expose`, numba, without the GIL): the
frame costs ~0.5 ms, bit for bit what the numpy expression gives.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt
from numba import njit

from runtime.parameters import load_parameters, param, validate_parameters
from sim.arena import Lighting

Image = npt.NDArray[np.uint8]
CAMERA_MODEL_NODE_NAME = "sim_camera_model"  # its section in config/sim_camera_model.yaml


@dataclass(frozen=True)
class ExposureParams:
    """How the camera is exposed under one lighting preset."""

    electrons_per_ms: float = param(unit="e-/ms", range=(0.0, 1e7), lo_open=True)
    """Photo-electrons per millisecond for a rendered value of 255 in this light."""
    exposure_ms: float = param(unit="ms", range=(0.01, 1000.0))
    """Exposure time."""
    gain: float = param(range=(1.0, 1000.0))
    """Analog gain over the full-well scale."""

    def __post_init__(self) -> None:
        validate_parameters(self)


@dataclass(frozen=True)
class CameraModelParams:
    """The sensor (``config/sim_camera_model.yaml``)."""

    light: ExposureParams
    dark: ExposureParams
    enabled: bool = param(description="false: the rendered frame as it is")
    full_well_e: float = param(unit="e-", range=(1.0, 1e7))
    """Electrons that fill the 8-bit range at gain 1."""
    read_noise_e: float = param(unit="e-", range=(0.0, 1000.0))
    """Gaussian read noise per pixel (RMS)."""
    motion_blur: bool = param(description="blur by the vehicle's motion during the exposure")

    def __post_init__(self) -> None:
        validate_parameters(self)

    def exposure(self, lighting: Lighting) -> ExposureParams:
        return self.light if lighting is Lighting.LIGHT else self.dark


def camera_model_params() -> CameraModelParams:
    """:class:`CameraModelParams` from ``config/sim_camera_model.yaml``."""
    return load_parameters(CameraModelParams, CAMERA_MODEL_NODE_NAME)


def motion_blur_px(velocity_body: npt.ArrayLike, rates_body: npt.ArrayLike, height: float,
                   focal_px: float, exposure_s: float) -> tuple[float, float]:
    """How far [px] the down camera's image moves during one exposure: ``(du, dv)``.

    ``velocity_body`` [m/s] and ``rates_body`` [rad/s] are FLU; the camera looks down
    with image up = body forward, image right = body right, at ``height`` [m] above the
    floor. Translation moves the floor by ``v / height`` rad/s; a roll rate p tilts the
    view to the right (the floor moves left in the image), a pitch rate q forward.
    """
    v = np.asarray(velocity_body, dtype=np.float64).reshape(3)
    w = np.asarray(rates_body, dtype=np.float64).reshape(3)
    h = max(height, 0.05)
    # the floor's apparent motion in the image: vehicle forward -> floor moves down (+v)
    du = (v[1] / h + w[0]) * focal_px * exposure_s  # left motion or right roll: floor right
    dv = (v[0] / h - w[1]) * focal_px * exposure_s  # forward motion: floor moves down
    return float(du), float(dv)


NOISE_POOL_FRAMES = 8  # the pool holds this many frames' worth of standard normals
MAX_BLUR_PX = 64.0  # longer smears are cut to this (a tumbling vehicle sees nothing anyway)


def _line_kernel(du: float, dv: float) -> npt.NDArray[np.float32] | None:
    length = math.hypot(du, dv)
    if not math.isfinite(length) or length < 0.5:
        return None
    if length > MAX_BLUR_PX:
        du, dv = du * MAX_BLUR_PX / length, dv * MAX_BLUR_PX / length
        length = MAX_BLUR_PX
    size = math.ceil(length) | 1
    kernel = np.zeros((size, size), dtype=np.float32)
    c = (size - 1) / 2.0
    steps = max(2, math.ceil(length * 2))
    for s in np.linspace(-0.5, 0.5, steps):
        x, y = c + s * du, c + s * dv
        kernel[round(y), round(x)] += 1.0
    return np.asarray(kernel / kernel.sum(), dtype=np.float32)


class CameraSensorModel:
    """Turns rendered frames into camera frames (see the module docstring)."""

    def __init__(self, params: CameraModelParams, lighting: Lighting, seed: int) -> None:
        self.params = params
        self.lighting = lighting
        self.exposure = params.exposure(lighting)
        self._rng = np.random.default_rng(seed)
        self._pool: npt.NDArray[np.float32] | None = None

    def _normals(self, shape: tuple[int, ...]) -> npt.NDArray[np.float32]:
        """Standard normals for one frame: a slice of the pool at a random offset."""
        size = math.prod(shape)
        if self._pool is None or self._pool.size < NOISE_POOL_FRAMES * size:
            self._pool = self._rng.standard_normal(NOISE_POOL_FRAMES * size, dtype=np.float32)
        start = int(self._rng.integers(0, self._pool.size - size + 1))
        return self._pool[start:start + size].reshape(shape)

    @property
    def exposure_s(self) -> float:
        return self.exposure.exposure_ms / 1000.0

    def apply(self, rendered: Image, blur_px: tuple[float, float] = (0.0, 0.0)) -> Image:
        """The camera's 8-bit frame of a rendered RGB ``uint8`` frame."""
        if not self.params.enabled:
            return rendered
        if rendered.dtype != np.uint8:
            raise ValueError(f"rendered: expected uint8, got {rendered.dtype}")
        e = self.exposure
        to_electrons = np.float32(e.electrons_per_ms * e.exposure_ms / 255.0)
        light: npt.NDArray[np.uint8] | npt.NDArray[np.float32] = rendered
        if self.params.motion_blur and (kernel := _line_kernel(*blur_px)) is not None:
            # large kernels go through the DFT: round-off can dip just below zero
            light = np.maximum(cv2.filter2D(rendered.astype(np.float32) * to_electrons, -1,
                                            kernel, borderType=cv2.BORDER_REFLECT), 0.0)
            to_electrons = np.float32(1.0)
        out = np.empty(rendered.shape, dtype=np.uint8)
        _expose(np.ascontiguousarray(light).reshape(-1), to_electrons,
                self._normals((light.size,)), np.float32(self.params.read_noise_e ** 2),
                np.float32(e.gain * 255.0 / self.params.full_well_e), out.reshape(-1))
        return out


@njit(cache=True, nogil=True)
def _expose(light: npt.NDArray[np.generic], to_electrons: np.float32,
            normals: npt.NDArray[np.float32], read_var: np.float32, to_dn: np.float32,
            out: npt.NDArray[np.uint8]) -> None:  # pragma: no cover - compiled
    """Steps 3-5 of the module docstring for each pixel, in one pass and float32: the
    electrons ``light * to_electrons``, their shot and read noise (``normals``), the gain
    and the 8-bit rounding (half to even, as ``np.rint``) and clipping. Compiled without
    the GIL, so the render thread's frames overlap the simulation."""
    for i in range(light.size):
        electrons = np.float32(light[i]) * to_electrons
        electrons = electrons + np.sqrt(electrons + read_var) * normals[i]
        dn = np.rint(electrons * to_dn)
        out[i] = 0 if dn < 0 else 255 if dn > 255 else np.uint8(dn)


__all__ = ["CAMERA_MODEL_NODE_NAME", "NOISE_POOL_FRAMES", "CameraModelParams", "CameraSensorModel",
           "ExposureParams", "camera_model_params", "motion_blur_px"]
