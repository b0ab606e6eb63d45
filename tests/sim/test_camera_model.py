"""sim/camera_model.py: the sensor turns rendered frames into 8-bit camera frames;
same seed, same frames; the dark preset is dim and noisy; motion smears."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from sim.arena import Lighting
from sim.camera_model import CameraSensorModel, camera_model_params, motion_blur_px

# a rendered-like frame: black and white stripes on mid grey
FRAME = np.full((60, 80, 3), 128, dtype=np.uint8)
FRAME[:, 20:30] = 0
FRAME[:, 50:60] = 255
PARAMS = replace(camera_model_params(), motion_blur=True)


def test_same_seed_same_frame_other_seed_other_noise():
    a = CameraSensorModel(PARAMS, Lighting.LIGHT, 1).apply(FRAME)
    b = CameraSensorModel(PARAMS, Lighting.LIGHT, 1).apply(FRAME)
    c = CameraSensorModel(PARAMS, Lighting.LIGHT, 2).apply(FRAME)
    assert a.dtype == np.uint8 and a.shape == FRAME.shape
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)


def test_dark_is_dimmer_and_noisier_relative_to_its_contrast():
    light = CameraSensorModel(PARAMS, Lighting.LIGHT, 1).apply(FRAME).astype(float)
    dark = CameraSensorModel(PARAMS, Lighting.DARK, 1).apply(FRAME).astype(float)

    def snr(img: np.ndarray) -> float:
        contrast = img[:, 50:60].mean() - img[:, 20:30].mean()
        return float(contrast / img[:, 35:45].std())

    assert dark[:, 50:60].mean() < 0.5 * light[:, 50:60].mean()
    assert snr(dark) < 0.5 * snr(light)


def test_light_keeps_the_frame_close():
    light = CameraSensorModel(PARAMS, Lighting.LIGHT, 1).apply(FRAME).astype(float)
    assert np.abs(light - FRAME).mean() < 6.0


def test_disabled_is_the_render():
    off = CameraSensorModel(replace(PARAMS, enabled=False), Lighting.DARK, 1)
    assert off.apply(FRAME) is FRAME


def test_motion_blur_smears_edges_along_the_motion():
    model = CameraSensorModel(replace(PARAMS, read_noise_e=0.0), Lighting.LIGHT, 1)
    sharp = model.apply(FRAME).astype(float)
    smeared = model.apply(FRAME, blur_px=(12.0, 0.0)).astype(float)
    # across the stripes (along u) the edge spreads; the stripe centre stays dark-ish
    assert smeared[:, 18].mean() < sharp[:, 18].mean() - 20
    assert smeared[:, 25].mean() > sharp[:, 25].mean() + 20


def test_blur_geometry():
    # forward at 1 m/s, 1 m up, 400 px focal, 10 ms: the floor moves 4 px down the image
    assert motion_blur_px([1, 0, 0], [0, 0, 0], 1.0, 400.0, 0.01) == pytest.approx((0.0, 4.0))
    # flying left: the floor moves right
    assert motion_blur_px([0, 1, 0], [0, 0, 0], 2.0, 400.0, 0.01)[0] == pytest.approx(2.0)


@pytest.mark.parametrize("lighting", [Lighting.LIGHT, Lighting.DARK])
def test_noise_has_the_sensor_mean_and_variance(lighting):
    # a flat field: each pixel's DN is gain_k * (e + sqrt(e + r^2) z), so across pixels
    # the mean is gain_k * e and the spread gain_k * sqrt(e + r^2)
    params = replace(PARAMS, motion_blur=False)
    model = CameraSensorModel(params, lighting, 7)
    flat = np.full((120, 160, 3), 60, dtype=np.uint8)
    out = np.concatenate([model.apply(flat).astype(float) for _ in range(4)])
    e = model.exposure
    electrons = 60 * e.electrons_per_ms * e.exposure_ms / 255.0
    k = e.gain * 255.0 / params.full_well_e
    assert out.mean() == pytest.approx(k * electrons, abs=0.6)  # rounding to DN: +-0.5
    assert out.std() == pytest.approx(k * np.sqrt(electrons + params.read_noise_e ** 2),
                                      rel=0.1, abs=0.3)


def test_successive_frames_have_different_noise():
    model = CameraSensorModel(PARAMS, Lighting.DARK, 3)
    flat = np.full((60, 80, 3), 128, dtype=np.uint8)
    a, b = model.apply(flat).astype(float), model.apply(flat).astype(float)
    assert a.std() > 1.0
    assert abs(np.corrcoef((a - a.mean()).ravel(), (b - b.mean()).ravel())[0, 1]) < 0.1


@pytest.mark.parametrize("lighting", [Lighting.LIGHT, Lighting.DARK])
@pytest.mark.parametrize("blur_px", [(0.0, 0.0), (3.0, 1.5)])
def test_the_compiled_pass_is_the_numpy_sensor_bit_for_bit(lighting, blur_px):
    """Steps 3-5 (noise, gain, rounding, clipping) as the numpy expression of the module
    docstring, with the same normals: the compiled pass must give the same bytes."""
    import cv2

    from sim.camera_model import _line_kernel

    rng = np.random.default_rng(7)
    rendered = rng.integers(0, 256, (48, 64, 3), dtype=np.uint8)
    ours = CameraSensorModel(camera_model_params(), lighting, 3)
    reference = CameraSensorModel(camera_model_params(), lighting, 3)
    for _ in range(3):
        e = reference.exposure
        electrons = rendered.astype(np.float32) * np.float32(
            e.electrons_per_ms * e.exposure_ms / 255.0)
        kernel = _line_kernel(*blur_px)
        if kernel is not None:
            electrons = np.maximum(cv2.filter2D(electrons, -1, kernel,
                                                borderType=cv2.BORDER_REFLECT), 0.0)
        normals = reference._normals((electrons.size,)).reshape(electrons.shape)
        noisy = electrons + np.sqrt(electrons + np.float32(reference.params.read_noise_e ** 2)) \
            * normals
        dn = np.rint(noisy * np.float32(e.gain * 255.0 / reference.params.full_well_e))
        expected = np.clip(dn, 0, 255).astype(np.uint8)
        np.testing.assert_array_equal(ours.apply(rendered, blur_px), expected)
