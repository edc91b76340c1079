"""The dig-level environments' Gymnasium face: one step per dig, the action a planner's (Gymnasium).

:class:`DigStepEnv` is what every dig-level environment shares around its task's core (a
:class:`~excavsim.envs.core.DigLevelCore`); each task that offers one subclasses it in its own folder.
:class:`PlannerPolicy` is a task's planner used as a policy through such an environment.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from excavsim.envs.core import EnvError, check_seed, check_vector
from excavsim.envs.render import RENDER_MODES, FrameRenderer, check_render_mode
from excavsim.envs.spaces import dict_space


class DigStepEnv(gym.Env):
    """What every dig-level environment shares (one step per dig, the action a planner's, in its
    units or normalized to [-1, 1]): spaces from the core's fields, seeding, the normalized action's
    mapping, rendering between digs and closing. A subclass names its core (:attr:`core_class`), its
    id for messages (:attr:`env_id`), what its action is (:attr:`action_noun`) and where its world is
    (:meth:`_world`).

    Seeding: ``reset(seed=s)`` runs the episode with seed ``s``, so the same seed and actions give the same
    episode bit for bit; ``reset()`` without a seed runs the spec's seed first, then seeds drawn from
    :attr:`np_random` (:func:`episode_seed`)."""

    metadata = {"render_modes": list(RENDER_MODES), "render_fps": 1}  # a frame per dig
    core_class: type  # a DigLevelCore
    env_id: str  # the id without its namespace, for messages
    action_noun = "dig action"

    def __init__(self, spec=None, *, render_mode: str | None = None, normalize_action: bool = False,
                 render_size: tuple[int, int] = (480, 360), **kwargs: Any):
        self.render_mode = check_render_mode(render_mode)
        self.core = self.core_class(spec, **kwargs)
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
        """The task's result of the last episode once it ended (see the class docstring), else None."""
        return self.core.result

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        """Start an episode (see the class docstring for seeding); returns (observation, info).

        Raises:
            EnvError: a seed outside [0, 2**32 - 1] or an option (none is defined).
        """
        if options:
            raise EnvError(f"{self.env_id} takes no reset options; given {sorted(options)}")
        return self.core.reset(episode_seed(self, seed))

    def step(self, action):
        """Dig ``action``; returns (observation, reward, terminated, truncated, info)."""
        if self.normalize_action:
            ones = np.ones(self.core.action_low.shape)
            a = check_vector(action, -ones, ones, f"the normalized {self.action_noun}")
            low, high = self.core.action_low, self.core.action_high
            action = low + (np.clip(a, -1.0, 1.0) + 1.0) / 2.0 * (high - low)
        return self.core.step(action)

    def _world(self):
        """The running episode's world (with ``model`` and ``data``), or None."""
        return getattr(self.core, "_sim", None)

    def render(self):
        """The frame now (the world between digs), (height, width, 3) uint8, with
        ``render_mode="rgb_array"``; None without a render mode or before the first reset.

        Raises:
            EnvError: no OpenGL backend works in this process.
        """
        world = self._world()
        if self.render_mode is None or world is None:
            return None
        return self._frames.render(world.model, world.data)

    def close(self):
        """Abandon the running episode and free the renderer (closing twice is fine)."""
        self._frames.close()
        self.core.close()

    def __del__(self):
        # a dropped environment ends its episode (its observers hear finished(None))
        core = getattr(self, "core", None)
        if core is not None:
            core.close()


def episode_seed(env: gym.Env, seed: int | None) -> int:
    """The seed of the episode ``env.reset(seed=seed)`` starts: ``seed``; without one, the spec's
    on the first reset (which also seeds ``np_random`` with it), then draws from ``np_random``."""
    if seed is not None:
        check_seed(seed)
        gym.Env.reset(env, seed=seed)
        chosen = seed
    elif env._resets == 0:
        chosen = env.core.spec.seed
        gym.Env.reset(env, seed=chosen)
    else:
        gym.Env.reset(env)
        chosen = int(env.np_random.integers(0, 2**32))
    env._resets += 1
    return chosen


class PlannerPolicy:
    """A task's planner as a policy of its dig-level environment: the planner's action on the current
    map (``info["planner_action"]``), and the middle of the action space in a cycle where the planner
    has none (there the environment digs what the task's loop digs and does not use the action).

    Through the environment it reproduces the task's own episode for the same spec and seed.

    Args:
        action_space: the environment's action space.
    """

    def __init__(self, action_space: gym.spaces.Box):
        self.default = ((action_space.low + action_space.high) / 2).astype(action_space.dtype)

    def __call__(self, observation, info: dict[str, Any]) -> np.ndarray:
        """The action for this cycle."""
        action = info.get("planner_action")
        return self.default.copy() if action is None else np.asarray(action, dtype=self.default.dtype)
