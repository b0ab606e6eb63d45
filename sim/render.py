"""Offscreen rendering of the scene's cameras and depth -> point cloud.

Rendering happens only when asked: :class:`SceneRenderer` creates a ``mujoco.Renderer``
(one GL context per image size) on first use. Headless machines set ``MUJOCO_GL=egl``
before ``mujoco`` is imported. The onboard cameras do not draw the drone's own geoms
(:data:`sim.mjcf.QUAD_GEOM_GROUP`); the top-down view draws everything.

Point clouds are in the depth camera's FLU frame (x forward along the optical axis, y
left, z up in the image), the ROS ``camera_link`` convention, not the optical frame.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from types import TracebackType
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

from runtime.errors import ParameterError
from runtime.executor import threads_allowed
from sim.mjcf import DEPTH_CAMERA, DOWN_CAMERA, QUAD_GEOM_GROUP, TOP_CAMERA
from sim.quadrotor import CameraParams

Image = npt.NDArray[np.uint8]
DepthImage = npt.NDArray[np.float32]
Points = npt.NDArray[np.float32]


@dataclass(frozen=True)
class CameraIntrinsics:
    """Pinhole intrinsics in pixels; pixel ``(u, v)`` has its centre at ``(u, v)``."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float

    @classmethod
    def from_fovy(cls, width: int, height: int, fovy: float) -> CameraIntrinsics:
        """Square-pixel camera with vertical field of view ``fovy`` [rad] (MuJoCo's model)."""
        focal = (height / 2.0) / math.tan(fovy / 2.0)
        return cls(width, height, focal, focal, (width - 1) / 2.0, (height - 1) / 2.0)

    @classmethod
    def from_camera(cls, params: CameraParams) -> CameraIntrinsics:
        """Intrinsics of an onboard camera."""
        return cls.from_fovy(params.width, params.height, params.fovy)

    def matrix(self) -> npt.NDArray[np.float64]:
        """The 3x3 camera matrix ``K``."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])


def depth_to_points(
    depth: DepthImage,
    intrinsics: CameraIntrinsics,
    min_range: float,
    max_range: float,
    stride: int = 1,
) -> Points:
    """Unproject a z-depth image [m] to an ``(N, 3)`` cloud in the camera FLU frame.

    Pixels with depth outside ``[min_range, max_range]`` (nothing hit, too close) are
    dropped; ``stride`` keeps every ``stride``-th row and column.
    """
    if depth.shape != (intrinsics.height, intrinsics.width):
        raise ParameterError(
            f"depth: shape {depth.shape} does not match the {intrinsics.width}x"
            f"{intrinsics.height} camera"
        )
    if stride < 1:
        raise ParameterError(f"stride: {stride} must be >= 1")
    v, u = np.mgrid[0 : intrinsics.height : stride, 0 : intrinsics.width : stride]
    z = depth[::stride, ::stride]
    keep = (z >= min_range) & (z <= max_range)
    z, u, v = z[keep], u[keep], v[keep]
    left = -(u - intrinsics.cx) * z / intrinsics.fx
    up = -(v - intrinsics.cy) * z / intrinsics.fy
    return np.stack((z, left, up), axis=1).astype(np.float32)


ONBOARD_MULTISAMPLES = 0
"""Anti-aliasing samples of the onboard cameras' buffers. None: ``benchmarks/bench_sitl.py``
decodes every pad marker alike with 0 and 4 samples at 640x480 and 320x240, and 4 samples
cost more per frame (its ``antialiasing`` figures); the top-down view (a picture for
people) keeps the model's 4."""

_LEAN_FLAGS = (mujoco.mjtRndFlag.mjRND_SHADOW, mujoco.mjtRndFlag.mjRND_REFLECTION,
               mujoco.mjtRndFlag.mjRND_SKYBOX)
"""Render passes the onboard cameras skip: shadow maps and mirror passes cost a software
renderer a pass each, and the cameras look down or ahead at the field, not the sky."""


#: headless backends whose GL contexts may live on any thread (GLFW's may not)
_OFF_MAIN_THREAD_GL = os.environ.get("MUJOCO_GL", "").lower() in ("egl", "osmesa")


def _render_thread() -> bool:
    """Whether frames may be drawn on the render thread (a headless GL backend, and
    threads allowed: :func:`runtime.executor.threads_allowed`)."""
    return _OFF_MAIN_THREAD_GL and threads_allowed()


def _rgb_camera(camera: str) -> None:
    if camera == DEPTH_CAMERA:
        raise ParameterError(f"camera: {DEPTH_CAMERA!r} renders depth only; use depth()")


class SceneRenderer:
    """Renders the down camera, the depth camera and the top-down view of a compiled scene.

    Each camera gets its own ``mujoco.Renderer`` on first use, with an offscreen buffer of
    the camera's own size (not the model's largest) and, for the onboard cameras,
    ``multisamples`` anti-aliasing samples and no shadow, reflection or skybox pass. The
    depth camera has its own renderer in depth mode: flat segment colours (MuJoCo's, no
    lighting), no textures, and only the depth buffer read back.
    """

    def __init__(self, model: mujoco.MjModel, *, multisamples: int = ONBOARD_MULTISAMPLES,
                 lean: bool = True) -> None:
        if multisamples < 0:
            raise ParameterError(f"multisamples: {multisamples} must be >= 0")
        self._model = model
        self._multisamples = multisamples
        self._lean = lean
        self._renderers: dict[str, mujoco.Renderer] = {}
        # each camera's render thread (made on its first render_later) and its renderer
        # there, as a GL context belongs to the thread that made it, and each camera's
        # frame in flight: a thread per camera, so one camera's frame never queues behind
        # another's (the depth cloud behind the down image, or the other way round)
        self._workers: dict[str, ThreadPoolExecutor] = {}
        self._threaded: dict[str, mujoco.Renderer] = {}
        self._in_flight: dict[str, Future[Image]] = {}
        self._onboard = mujoco.MjvOption()
        self._onboard.geomgroup[QUAD_GEOM_GROUP] = 0
        self._onboard.sitegroup[:] = 0
        self._depth_option = mujoco.MjvOption()
        self._depth_option.geomgroup[QUAD_GEOM_GROUP] = 0
        self._depth_option.sitegroup[:] = 0
        self._depth_option.flags[mujoco.mjtVisFlag.mjVIS_TEXTURE] = 0
        self._overview = mujoco.MjvOption()
        self._overview.sitegroup[:] = 0

    def __enter__(self) -> SceneRenderer:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()

    def close(self) -> None:
        """Release every GL context (the render thread's on that thread), then the thread."""
        for renderer in self._renderers.values():
            renderer.close()
        self._renderers.clear()
        workers, self._workers = self._workers, {}
        try:
            for future in self._in_flight.values():
                future.exception()  # wait for it (its reader, if any, sees its error)
            for camera, worker in workers.items():
                if (renderer := self._threaded.get(camera)) is not None:
                    worker.submit(renderer.close).result()
        finally:
            for worker in workers.values():
                worker.shutdown()
        self._threaded.clear()
        self._in_flight.clear()

    def camera_size(self, camera: str) -> tuple[int, int]:
        """``(width, height)`` [px] of a named camera, from the model."""
        width, height = self._model.cam_resolution[self._model.camera(camera).id]
        return int(width), int(height)

    def _renderer(self, camera: str) -> mujoco.Renderer:
        renderer = self._renderers.get(camera)
        if renderer is None:
            renderer = self._renderers[camera] = self._make_renderer(camera)
        return renderer

    def _make_renderer(self, camera: str) -> mujoco.Renderer:
        """A renderer whose GL buffer is the camera's size: MuJoCo sizes it from the
        model's ``offwidth``/``offheight``/``offsamples``, set here only while it is made."""
        width, height = self.camera_size(camera)
        model = self._model
        vis_global, quality = model.vis.global_, model.vis.quality
        saved = (vis_global.offwidth, vis_global.offheight, quality.offsamples)
        onboard = camera != TOP_CAMERA
        try:
            vis_global.offwidth, vis_global.offheight = width, height
            if onboard:
                quality.offsamples = self._multisamples
            renderer = mujoco.Renderer(model, height=height, width=width)
        finally:
            vis_global.offwidth, vis_global.offheight, quality.offsamples = saved
        if onboard and self._lean:
            for flag in _LEAN_FLAGS:
                renderer.scene.flags[flag] = False
        if camera == DEPTH_CAMERA:
            renderer.enable_depth_rendering()  # segment colours, no lighting; depth read
        return renderer

    def rgb(self, data: mujoco.MjData, camera: str) -> Image:
        """An RGB image from ``camera`` (onboard cameras hide the drone itself)."""
        _rgb_camera(camera)
        renderer = self._renderer(camera)
        self._capture(renderer, data, camera)
        image: Image = renderer.render()
        return image

    def _capture(self, renderer: mujoco.Renderer, data: mujoco.MjData, camera: str) -> None:
        """Put ``data`` as ``camera`` sees it in ``renderer``'s scene (no GL call)."""
        option = (self._depth_option if camera == DEPTH_CAMERA
                  else self._overview if camera == TOP_CAMERA else self._onboard)
        renderer.update_scene(data, camera=camera, scene_option=option)

    def render_later(self, data: mujoco.MjData, camera: str,
                     then: Callable[[Any], Any] | None = None) -> Future[Any]:
        """What :meth:`rgb` (or, for the depth camera, :meth:`depth`) gives now, rendered
        on the camera's render thread: the scene is captured here, at once, and drawn there while
        the caller goes on (MuJoCo releases the GIL while it renders, so the frame costs
        the caller little on a second core). ``then`` runs on the render thread with the
        image (a sensor model), in the order the frames were asked for.

        A camera's previous frame must be drawn before its scene is captured again: this
        waits for it (a frame period longer than a render never waits). With a GL backend
        whose contexts must stay on the main thread (GLFW, MuJoCo's default on a desktop)
        the frame is drawn here, at once: the same image, only not overlapped.
        """
        previous = self._in_flight.get(camera)
        if previous is not None:
            previous.exception()  # its render reads the scene captured below
        worker = None
        if _render_thread() and (worker := self._workers.get(camera)) is None:
            worker = self._workers[camera] = ThreadPoolExecutor(
                1, thread_name_prefix=f"scene_renderer_{camera}")
        if worker is None:
            renderer = self._renderer(camera)
        elif (renderer := self._threaded.get(camera)) is None:
            # made on the render thread: its GL context is current there
            renderer = self._threaded[camera] = worker.submit(self._make_renderer,
                                                              camera).result()
        self._capture(renderer, data, camera)

        def draw() -> Any:
            image = renderer.render()
            return image if then is None else then(image)

        if worker is None:
            done: Future[Any] = Future()
            done.set_result(draw())
            return done
        future = self._in_flight[camera] = worker.submit(draw)
        return future

    def depth(self, data: mujoco.MjData, camera: str = DEPTH_CAMERA) -> DepthImage:
        """Z-depth [m] along ``camera``'s optical axis, per pixel."""
        if camera != DEPTH_CAMERA:
            raise ParameterError(f"camera: depth() renders {DEPTH_CAMERA!r}, not {camera!r}")
        renderer = self._renderer(camera)
        renderer.update_scene(data, camera=camera, scene_option=self._depth_option)
        depth: DepthImage = renderer.render()
        return depth

    def down_image(self, data: mujoco.MjData) -> Image:
        """The 640x480 downward camera (image up = body forward)."""
        return self.rgb(data, DOWN_CAMERA)

    def top_view(self, data: mujoco.MjData) -> Image:
        """Orthographic top-down view of the whole field (image up = north)."""
        return self.rgb(data, TOP_CAMERA)


class DepthPointCloud:
    """The forward depth camera as a sensor: noisy point clouds in its FLU frame.

    Gaussian noise of ``noise_std`` [m] is added to each pixel's depth (along its ray)
    from a generator seeded with ``seed``; ``noise_std = 0`` gives exact points.
    """

    def __init__(
        self,
        renderer: SceneRenderer,
        params: CameraParams,
        *,
        noise_std: float,
        seed: int = 0,
        stride: int = 1,
    ) -> None:
        if not (math.isfinite(noise_std) and noise_std >= 0.0):
            raise ParameterError(f"noise_std: {noise_std} m must be >= 0")
        self._renderer = renderer
        self._params = params
        self._noise_std = noise_std
        self._rng = np.random.default_rng(seed)
        self._stride = stride
        self.intrinsics = CameraIntrinsics.from_camera(params)

    def points(self, data: mujoco.MjData) -> Points:
        """Render the depth camera and return an ``(N, 3)`` float32 cloud [m]."""
        return self.to_points(self._renderer.depth(data, DEPTH_CAMERA))

    def points_later(self, data: mujoco.MjData) -> Future[Points]:
        """:meth:`points`, rendered and made on the render thread
        (:meth:`SceneRenderer.render_later`): the same clouds, in the same order."""
        return self._renderer.render_later(data, DEPTH_CAMERA, self.to_points)

    def to_points(self, depth: DepthImage) -> Points:
        """The noisy cloud of one rendered depth image (draws this frame's noise)."""
        if self._noise_std > 0.0:
            noise = self._rng.normal(0.0, self._noise_std, depth.shape)
            depth = (depth + noise).astype(np.float32)
        return depth_to_points(
            depth, self.intrinsics, self._params.near, self._params.far, self._stride
        )
