"""``excavsim/TrenchJoint-v0`` and ``excavsim/TrenchJointDig-v0``: set-point rates of the arm's
servos at the control rate (Gymnasium).

:class:`TrenchJointEnv` is the Gymnasium face of :class:`~excavsim.envs.joint_core.JointCore`.
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np

from excavsim.envs.dig_env import _episode_seed
from excavsim.envs.joint_core import DIG_TASK, TRENCH_TASK, JointCore
from excavsim.envs.render import RENDER_MODES, FrameRenderer, check_render_mode
from excavsim.envs.spaces import dict_space

class TrenchJointEnv(gym.Env):
    """The trenching world at the control rate (100 Hz): the agent drives the servos.

    See :class:`~excavsim.envs.joint_core.JointCore` for the rules, the start and the reward term
    by term. Spaces (docs/environments.md has the tables):

    * action: ``Box(4,)`` float32 in [-1, 1]: the set-point rates of waist, shoulder, elbow and
      wrist pitch as fractions of their flow limits (the wrist's yaw and roll hold their home angles);
    * observation: ``Dict`` of float32 boxes ``q``, ``qdot`` (6 joint angles [rad] and velocities
      [rad/s]), ``ft`` (the F/T reading: soil force [N] and moment [N m] on the bucket about its tip,
      tip frame), ``tip`` (tip x, y, z [m] and pitch [rad] from the robot's kinematic model),
      ``patch`` (2 x P x P: the scanned terrain's and the goal's heights around the tip, relative to
      the tip [m]) and ``time_left`` (1,) [s].

    ``terminated`` when a scan shows the trench within tolerance or the world diverged;
    ``truncated`` after ``max_time_s``. ``info["reward_terms"]`` splits each reward. Seeding as
    :class:`~excavsim.envs.dig_env.TrenchDigEnv`; ``reset(options=...)`` takes
    :data:`~excavsim.envs.joint_core.START_OPTIONS`.

    Args:
        spec, weights, max_time_s, scan_period_s, patch_size, patch_spacing_m, start, robot_path, scene_path:
            as :class:`~excavsim.envs.joint_core.JointCore`.
        render_mode: None (the default) or ``"rgb_array"``: :meth:`render` returns a frame from
            MuJoCo's offscreen renderer (see :mod:`excavsim.envs.render` for the GL backends).
        render_size: (width, height) of the frames [pixels].
    """

    metadata = {"render_modes": list(RENDER_MODES), "render_fps": 100}

    def __init__(self, spec=None, *, render_mode: str | None = None, render_size: tuple[int, int] = (480, 360),
                 **kwargs: Any):
        self.render_mode = check_render_mode(render_mode)
        self.core = JointCore(spec, **kwargs)
        self.action_space = gym.spaces.Box(self.core.action_low.astype(np.float32),
                                           self.core.action_high.astype(np.float32), dtype=np.float32)
        self.observation_space = dict_space(self.core.fields)
        self.metadata = {"render_modes": list(RENDER_MODES), "render_fps": round(1.0 / self.core.control_dt)}
        goal = self.core.resolved.goal
        x = (goal.near_x_m + goal.far_x_m) / 2
        w = math.radians(goal.waist_deg)
        self._frames = FrameRenderer(*render_size, lookat=(x * math.cos(w), x * math.sin(w), goal.surface_z_m))
        self._resets = 0

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        """A fresh world (see the class docstring for seeding and options); returns (observation, info).

        Raises:
            EnvError: a seed outside [0, 2**32 - 1] or a bad option.
        """
        return self.core.reset(_episode_seed(self, seed), options)

    def step(self, action):
        """One control step; returns (observation, reward, terminated, truncated, info)."""
        return self.core.step(action)

    def render(self):
        """The frame now, (height, width, 3) uint8, with ``render_mode="rgb_array"``; None without a
        render mode or before the first reset.

        Raises:
            EnvError: no OpenGL backend works in this process.
        """
        if self.render_mode is None or self.core.sim is None:
            return None
        return self._frames.render(self.core.sim.model, self.core.sim.data)

    def close(self):
        """Free the world and the renderer (closing twice is fine)."""
        self._frames.close()
        self.core.close()
