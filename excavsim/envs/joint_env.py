"""``excavsim/TrenchJoint-v0``: set-point rates of the arm's servos at the control rate (Gymnasium).

:class:`TrenchJointEnv` is the Gymnasium face of :class:`~excavsim.envs.joint_core.JointCore`.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from excavsim.envs.core import EnvError
from excavsim.envs.joint_core import JointCore
from excavsim.envs.dig_env import _episode_seed
from excavsim.envs.spaces import dict_space


class TrenchJointEnv(gym.Env):
    """The trenching world at the control rate (100 Hz): the agent drives the servos.

    See :class:`~excavsim.envs.joint_core.JointCore` for the rules. Spaces:

    * action: ``Box(4,)`` float64 in [-1, 1]: the set-point rates of waist, shoulder, elbow and
      wrist pitch as fractions of their flow limits (the wrist's yaw and roll hold their home angles);
    * observation: ``Dict`` of ``q``, ``qdot`` (6 joint angles [rad] and velocities [rad/s]), ``ft``
      (the F/T reading: soil force [N] and moment [N m] on the bucket about its tip, tip frame),
      ``tip`` (tip x, y, z [m] and pitch [rad] from the robot's kinematic model), ``patch`` (2 x P x
      P float32: the scanned terrain's and the goal's heights around the tip, relative to the tip
      [m]) and ``time_left`` [s].

    Reward per step: litres removed above the goal inside its footprint (``cut_per_l``) and dumped
    to the spoil (``dump_per_l``), less litres dug below the goal (``overdig_per_l``) and seconds of
    each driven joint at 97 % of its relief limit (``saturation_per_s``), on the true terrain.
    ``terminated`` when a scan shows the trench within tolerance or the world diverged; ``truncated``
    after ``max_time_s``. Seeding as :class:`~excavsim.envs.dig_env.TrenchDigEnv`.

    Args:
        spec, weights, max_time_s, scan_period_s, patch_size, patch_spacing_m, robot_path,
            scene_path: as :class:`~excavsim.envs.joint_core.JointCore`.
        render_mode: only None.
    """

    metadata = {"render_modes": []}

    def __init__(self, spec=None, *, render_mode: str | None = None, **kwargs: Any):
        if render_mode is not None:
            raise EnvError(f"render_mode must be None (no render modes); given {render_mode!r}")
        self.render_mode = None
        self.core = JointCore(spec, **kwargs)
        self.action_space = gym.spaces.Box(self.core.action_low, self.core.action_high, dtype=np.float64)
        self.observation_space = dict_space(self.core.fields)
        self.metadata = {"render_modes": [], "render_fps": round(1.0 / self.core.control_dt)}
        self._resets = 0

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        """A fresh world (see the class docstring for seeding); returns (observation, info).

        Raises:
            EnvError: a seed outside [0, 2**32 - 1] or an option (none is defined).
        """
        if options:
            raise EnvError(f"TrenchJoint-v0 takes no reset options; given {sorted(options)}")
        return self.core.reset(_episode_seed(self, seed))

    def step(self, action):
        """One control step; returns (observation, reward, terminated, truncated, info)."""
        return self.core.step(action)

    def close(self):
        """Free the world (closing twice is fine)."""
        self.core.close()
