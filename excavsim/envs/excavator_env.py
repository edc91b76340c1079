"""``excavsim/ExcavatorJoint-v0``: a hydraulic excavator's four valves at the control rate (Gymnasium).

:class:`ExcavatorJointEnv` is the Gymnasium face of :class:`~excavsim.envs.excavator_core.ExcavatorJointCore`.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from excavsim.envs.dig_env import _episode_seed
from excavsim.envs.excavator_core import ExcavatorJointCore
from excavsim.envs.render import RENDER_MODES, FrameRenderer, check_render_mode
from excavsim.envs.spaces import dict_space


class ExcavatorJointEnv(gym.Env):
    """An excavator (the TB035 by default) digging a goal region of its pit at 50 Hz: the agent drives the
    valves of swing, boom, stick and bucket.

    See :class:`~excavsim.envs.excavator_core.ExcavatorJointCore` for the rules, the start and the reward
    term by term (docs/environments.md has the tables):

    * action: ``Box(4,)`` float32 in [-1, 1]: the set-point rates of swing, boom, stick and bucket as
      fractions of their flow limits (the pumps share their flow between functions);
    * observation: ``Dict`` of float32 boxes ``q``, ``qdot``, ``cylinder_force``, ``tip``, ``bucket_soil``,
      ``region_soil``, ``time_left``.

    ``terminated`` when 5 % of the region's soil is left or the world diverged; ``truncated`` after
    ``max_time_s``. Seeding as :class:`~excavsim.envs.dig_env.TrenchDigEnv`: ``reset(seed=s)`` starts
    episode ``s``; the first reset without a seed starts the core's ``seed``, later ones draw from
    ``np_random``. The same seed gives the same episode.

    Args:
        machine, soil, weights, max_time_s, seed: as :class:`~excavsim.envs.excavator_core.ExcavatorJointCore`.
        render_mode: None or ``"rgb_array"`` (MuJoCo's offscreen renderer).
        render_size: (width, height) of the frames [pixels].
    """

    metadata = {"render_modes": list(RENDER_MODES), "render_fps": 50}

    def __init__(self, machine: str = "tb035", *, render_mode: str | None = None,
                 render_size: tuple[int, int] = (480, 360), **kwargs: Any):
        self.render_mode = check_render_mode(render_mode)
        self.core = ExcavatorJointCore(machine, **kwargs)
        self.action_space = gym.spaces.Box(self.core.action_low.astype(np.float32),
                                           self.core.action_high.astype(np.float32), dtype=np.float32)
        self.observation_space = dict_space(self.core.fields)
        goal = self.core.goal
        self._frames = FrameRenderer(*render_size, lookat=((goal["near_x_m"] + goal["far_x_m"]) / 2, 0.0, 0.0))
        self._resets = 0

    @property
    def sim(self):
        """The world (for the recorder and renderers)."""
        return self.core.world

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        """A fresh world; returns (observation, info).

        Raises:
            EnvError: a seed outside [0, 2**32 - 1] or options given.
        """
        return self.core.reset(_episode_seed(self, seed), options)

    def step(self, action):
        """One control step; returns (observation, reward, terminated, truncated, info)."""
        return self.core.step(action)

    def render(self):
        """The frame now, (height, width, 3) uint8, with ``render_mode="rgb_array"``; None otherwise."""
        if self.render_mode is None or self.core.world is None:
            return None
        return self._frames.render(self.core.world.model, self.core.world.data)

    def close(self):
        """Free the world and the renderer (closing twice is fine)."""
        self._frames.close()
        self.core.close()
