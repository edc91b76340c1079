"""``excavsim/LoadDig-v0``: loading from a pile in MuJoCo, one step per dig, the action the loading
planner's (Gymnasium).

:class:`LoadDigEnv` is the Gymnasium face of :class:`~excavsim.envs.load_core.LoadCore`;
:class:`LoadPlannerPolicy` is the loading planner used as a policy through it.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from excavsim.envs.core import EnvError, check_vector
from excavsim.envs.dig_env import _episode_seed
from excavsim.envs.load_core import LoadCore
from excavsim.envs.render import RENDER_MODES, FrameRenderer, check_render_mode
from excavsim.envs.spaces import dict_space


class LoadDigEnv(gym.Env):
    """A loading episode (front loader or front shovel, a pile in a lane), one step per dig.

    See :class:`~excavsim.envs.load_core.LoadCore` for the rules (snapping to the planner's grid,
    the nearest feasible cell for an infeasible one, the reward's terms). Spaces:

    * action: ``Box(2,)`` float32 (k, alpha) from the planner grid's minima to its maxima [m, rad]
      (``Box(3,)`` (k, alpha, r) with ``parameterization: k_alpha_r`` in configs/loading.yaml); with
      ``normalize_action=True`` the same shape in [-1, 1], mapped linearly onto that box;
    * observation: ``Dict`` of ``sections`` (3 x 170 float32: the scanned map's middle, near-side and
      far-side sections every 5 cm along the lane), ``joints`` (the encoders), ``reference`` (the
      foot k is measured from, the shovel's base), ``section`` (``Discrete(3)``, the section the
      cycle digs) and ``digs_left`` (``Discrete``).

    ``terminated`` when the episode ends ``done`` (the map holds no dig of minimal utility on any
    section: the task's done test), ``no_dig`` (the dig's poses are out of the machine's reach) or
    ``diverged``; ``truncated`` when the dig budget is spent. ``info``: ``planner_action`` (the
    planner's action on this cycle's map, None once the episode ended), ``planner_section``,
    ``map_soil_m3`` (the soil the map shows above the ground: the mind's view); after a dig ``dig``
    (what was dug: k, h, alpha, d1, r, foot, base_x, section, planned, bucket, delivered, spilled
    and lane volumes [m^3]), ``reward_terms``, ``executed_cell`` (grid indices of k, alpha, r),
    ``snapped_to_allowed`` and ``planner_cell`` (the planner's own dig was dug); at the end
    ``episode`` (:func:`~excavsim.loop.scenario.loading_summary` without its wall time). The
    :class:`~excavsim.tasks.load.in_mujoco.MujocoRun` is :attr:`result` once the episode ended.

    Seeding as :class:`~excavsim.envs.dig_env.TrenchDigEnv`: ``reset(seed=s)`` runs the episode with
    seed ``s`` (the soil, the scanner's noise and drift); ``reset()`` without a seed runs the spec's
    seed first, then seeds drawn from :attr:`np_random`.

    Args:
        spec, weights, observer: as :class:`~excavsim.envs.load_core.LoadCore`.
        normalize_action: the action in [-1, 1] instead of the planner's units.
        render_mode: None (the default) or ``"rgb_array"`` (a frame of the world between digs).
        render_size: (width, height) of the frames [pixels].
    """

    metadata = {"render_modes": list(RENDER_MODES), "render_fps": 1}  # a frame per dig

    def __init__(self, spec=None, *, render_mode: str | None = None, normalize_action: bool = False,
                 render_size: tuple[int, int] = (480, 360), **kwargs: Any):
        self.render_mode = check_render_mode(render_mode)
        self.core = LoadCore(spec, **kwargs)
        self.normalize_action = bool(normalize_action)
        if self.normalize_action:
            self.action_space = gym.spaces.Box(-1.0, 1.0, shape=self.core.action_low.shape, dtype=np.float32)
        else:
            self.action_space = gym.spaces.Box(self.core.action_low.astype(np.float32),
                                               self.core.action_high.astype(np.float32), dtype=np.float32)
        self.observation_space = dict_space(self.core.fields)
        self._frames = FrameRenderer(*render_size)
        self._resets = 0

    @property
    def result(self):
        """The :class:`~excavsim.tasks.load.in_mujoco.MujocoRun` of the last episode once it ended, else None."""
        return self.core.result

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        """Start an episode (see the class docstring for seeding); returns (observation, info).

        Raises:
            EnvError: a seed outside [0, 2**32 - 1] or an option (none is defined).
        """
        if options:
            raise EnvError(f"LoadDig-v0 takes no reset options; given {sorted(options)}")
        return self.core.reset(_episode_seed(self, seed))

    def step(self, action):
        """Dig ``action``; returns (observation, reward, terminated, truncated, info)."""
        if self.normalize_action:
            ones = np.ones(self.core.action_low.shape)
            a = check_vector(action, -ones, ones, "the normalized loading action")
            low, high = self.core.action_low, self.core.action_high
            action = low + (np.clip(a, -1.0, 1.0) + 1.0) / 2.0 * (high - low)
        return self.core.step(action)

    def render(self):
        """The frame now (the world between digs), (height, width, 3) uint8, with
        ``render_mode="rgb_array"``; None without a render mode or before the first reset.

        Raises:
            EnvError: no OpenGL backend works in this process.
        """
        task = self.core._task
        if self.render_mode is None or task is None:
            return None
        return self._frames.render(task.world.model, task.world.data)

    def close(self):
        """Abandon the running episode and free the renderer (closing twice is fine)."""
        self._frames.close()
        self.core.close()

    def __del__(self):
        core = getattr(self, "core", None)
        if core is not None:
            core.close()


class LoadPlannerPolicy:
    """The loading planner as a policy of :class:`LoadDigEnv`: the planner's action on the current map
    (``info["planner_action"]``), the middle of the action space once the episode ended (the step
    that reports the end digs nothing). Through the environment it reproduces the plain loading episode.

    Args:
        action_space: the environment's action space (in the planner's units).
    """

    def __init__(self, action_space: gym.spaces.Box):
        self.default = ((action_space.low + action_space.high) / 2).astype(action_space.dtype)

    def __call__(self, observation, info: dict[str, Any]) -> np.ndarray:
        """The action for this cycle."""
        action = info.get("planner_action")
        return self.default.copy() if action is None else np.asarray(action, dtype=self.default.dtype)
