"""Offscreen frames of the simulated world for the environments' ``render_mode="rgb_array"``.

MuJoCo's offscreen renderer (:class:`mujoco.Renderer`) needs an OpenGL backend chosen by the
``MUJOCO_GL`` environment variable before MuJoCo is imported: ``egl`` (headless; Debian packages
``libegl1`` and ``libgl1-mesa-dri``), ``osmesa`` (software; ``libosmesa6``) or ``glfw`` (a display).
The renderer is made on the first frame, not with the environment, so that an environment created
with ``render_mode="rgb_array"`` (Stable-Baselines3's ``make_vec_env`` asks for it) costs nothing and
needs no GL until a frame is asked for; where no backend works, that first frame raises an
:class:`~excavsim.envs.core.EnvError` naming the backend.
"""

from __future__ import annotations

import os

import mujoco
import numpy as np

from excavsim.envs.core import EnvError

RENDER_MODES = ("rgb_array",)


class RenderModeError(EnvError, TypeError):
    """A ``render_mode`` the environment does not offer. Also a ``TypeError``, as Gymnasium's and
    Stable-Baselines3's ``make`` helpers expect of a constructor argument they may retry without."""


def check_render_mode(render_mode: str | None) -> str | None:
    """``render_mode`` if it is None or one of :data:`RENDER_MODES`."""
    if render_mode is not None and render_mode not in RENDER_MODES:
        raise RenderModeError(f"render_mode must be None or one of {', '.join(map(repr, RENDER_MODES))}; "
                              f"given {render_mode!r}")
    return render_mode


def gl_backend() -> str:
    """The OpenGL backend MuJoCo uses in this process (``MUJOCO_GL``, or ``(unset)``)."""
    return os.environ.get("MUJOCO_GL", "(unset)")


_AVAILABLE: dict[str, str | None] = {}


def offscreen_error() -> str | None:
    """Why MuJoCo's offscreen renderer does not work in this process (None when it does): tried
    once per backend on a one-geom model."""
    backend = gl_backend()
    if backend not in _AVAILABLE:
        model = mujoco.MjModel.from_xml_string("<mujoco><worldbody><geom size='1'/></worldbody></mujoco>")
        frames = FrameRenderer(8, 8)
        try:
            frames.render(model, mujoco.MjData(model))
            _AVAILABLE[backend] = None
        except EnvError as exc:
            _AVAILABLE[backend] = str(exc)
        finally:
            frames.close()
    return _AVAILABLE[backend]


class FrameRenderer:
    """RGB frames of a world from a free camera looking at ``lookat``.

    Args:
        width, height: the frame's size [pixels] (at most the model's offscreen buffer, 640 x 480 by default).
        lookat: the point the camera looks at [m]; distance [m], azimuth and elevation [deg]: where it stands.
    """

    def __init__(self, width: int = 480, height: int = 360, *, lookat=(2.0, 0.0, 0.5), distance: float = 4.0,
                 azimuth: float = 135.0, elevation: float = -30.0):
        self.width, self.height = int(width), int(height)
        self.camera = mujoco.MjvCamera()
        self.camera.lookat[:] = lookat
        self.camera.distance, self.camera.azimuth, self.camera.elevation = distance, azimuth, elevation
        self._renderer: mujoco.Renderer | None = None
        self._model: mujoco.MjModel | None = None

    def render(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        """The frame (height, width, 3) uint8 of ``data`` now.

        Raises:
            EnvError: no OpenGL backend works in this process (the message names ``MUJOCO_GL``).
        """
        if self._renderer is None or self._model is not model:
            self.close()
            try:
                self._renderer = mujoco.Renderer(model, self.height, self.width)
            except Exception as exc:  # noqa: BLE001 - each backend fails its own way (AttributeError, FatalError, EGLError)
                raise EnvError(
                    f"render_mode='rgb_array' needs an OpenGL backend for MuJoCo's offscreen renderer; MUJOCO_GL="
                    f"{gl_backend()} gave none ({type(exc).__name__}: {exc}). Set MUJOCO_GL=egl before importing "
                    f"MuJoCo (Debian packages libegl1 and libgl1-mesa-dri) or MUJOCO_GL=osmesa (libosmesa6)") from exc
            self._model = model
        self._renderer.update_scene(data, camera=self.camera)
        return self._renderer.render()

    def close(self) -> None:
        """Free the GL context (closing twice is fine)."""
        if self._renderer is not None:
            try:
                self._renderer.close()
            except Exception:  # noqa: BLE001 - a context already torn down at interpreter exit
                pass
        self._renderer = None
        self._model = None
