"""The joint-level environments' Gymnasium face: any machine's digging joints at its control rate.

:class:`JointEnv` is the Gymnasium face of :class:`~excavsim.envs.joint_core.JointCore`; the joint-level ids
(the platform's ``excavsim/ExcavatorJoint-v0``, the tasks' own: a task's plug-in contributes them) are
registrations of it with their goal and defaults (:mod:`excavsim.envs`).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from excavsim.envs.dig_env import episode_seed
from excavsim.envs.joint_core import JointCore
from excavsim.envs.render import RENDER_MODES, FrameRenderer, check_render_mode
from excavsim.envs.spaces import dict_space


class JointEnv(gym.Env):
    """A trenching machine at its control rate (the T3's 100 Hz, an excavator's 50 Hz): the agent drives
    the set-point rates of its waist or swing and its planar three joints.

    See :class:`~excavsim.envs.joint_core.JointCore` for the machine's part (the action, the
    proprioception) and its goals (a task's, found through its plug-in,
    or the platform's :class:`~excavsim.envs.joint_region.JointRegion`) for the start, the task's observation entries and the
    reward term by term. Spaces (docs/environments.md has the tables):

    * action: ``Box(4,)`` float32 in [-1, 1]: the driven joints' set-point rates as fractions of their ranges
      (on the T3 the wrist's yaw and roll hold their home angles; on an excavator the pumps share their flow);
    * observation: ``Dict`` of float32 boxes: ``q``, ``qdot`` and ``ft`` (the T3's wrist F/T) or
      ``cylinder_force`` (an excavator's), then the goal's: the trench's ``tip``, ``patch``, ``time_left``;
      the region's ``tip``, ``bucket_soil``, ``region_soil``, ``time_left``.

    ``terminated`` when the goal is reached or the world diverged; ``truncated`` after ``max_time_s``.
    ``info["reward_terms"]`` splits each reward. Seeding as :class:`~excavsim.envs.dig_env.DigStepEnv`:
    ``reset(seed=s)`` starts episode ``s``; the first reset without a seed starts the spec's ``seed``, later
    ones draw from ``np_random``; the same seed gives the same episode. ``reset(options=...)`` takes the
    goal's reset options (a task goal's own ``START_OPTIONS``; the region takes
    none).

    Args:
        spec, goal, machine, soil, seed, weights, max_time_s, robot_path, scene_path, and the goal's settings
            (the trench's ``scan_period_s``, ``patch_size``, ``patch_spacing_m``, ``start``): as
            :class:`~excavsim.envs.joint_core.JointCore`.
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
        self._frames = FrameRenderer(*render_size, lookat=self.core.goal.lookat)
        self._resets = 0

    @property
    def sim(self):
        """The world (for recorders and renderers; None before the first reset)."""
        return self.core.sim

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        """A fresh world (see the class docstring for seeding and options); returns (observation, info).

        Raises:
            EnvError: a seed outside [0, 2**32 - 1] or a bad option.
        """
        return self.core.reset(episode_seed(self, seed), options)

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
