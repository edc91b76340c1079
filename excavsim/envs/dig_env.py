"""``excavsim/TrenchDig-v0``: Singh's trenching action as the action, one step per dig (Gymnasium).

:class:`TrenchDigEnv` is the Gymnasium face of :class:`~excavsim.envs.core.DigCore` (the episode
loop of ``excavsim trench`` with the agent choosing each trenching action); :class:`PlannerPolicy`
is the planner used as a policy through it.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from excavsim.envs.core import DigCore, EnvError, check_seed, check_vector
from excavsim.envs.render import RENDER_MODES, FrameRenderer, check_render_mode
from excavsim.envs.spaces import dict_space


class DigStepEnv(gym.Env):
    """What every dig-level environment shares (one step per dig, the action a planner's, in its
    units or normalized to [-1, 1]): spaces from the core's fields, seeding, the normalized action's
    mapping, rendering between digs and closing. A subclass names its core (:attr:`core_class`), its
    id for messages (:attr:`env_id`), what its action is (:attr:`action_noun`) and where its world is
    (:meth:`_world`)."""

    metadata = {"render_modes": list(RENDER_MODES), "render_fps": 1}  # a frame per dig
    core_class: type = DigCore
    env_id = "TrenchDig-v0"
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
        return self.core.reset(_episode_seed(self, seed))

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


class TrenchDigEnv(DigStepEnv):
    """A trenching episode, one step per dig: the action is (k, alpha, d1) [m, rad, m].

    See :class:`~excavsim.envs.core.DigCore` for the rules (snapping to the planner's grid, the
    nearest allowed cell for an infeasible one, the fallback). Spaces:

    * action: ``Box(3,)`` float32 from the planner grid's (k_min, alpha_min, d1_min) to its maxima
      (in metres and radians, deliberately: the planner's units); with ``normalize_action=True``
      ``Box(3,)`` in [-1, 1], mapped linearly onto that box (-1 the minima, 1 the maxima);
    * observation: ``Dict`` of ``elevation``, ``goal_mask``, ``goal_depth`` (lateral x radial
      float32 grids around the goal, from the scanned map), ``ft`` (the last dig's peak and mean F/T
      force in the soil [N]), ``outcome`` (``Discrete``, an index of
      :data:`~excavsim.envs.core.OUTCOMES`) and ``digs_left`` (``Discrete``).

    Reward per dig: ``removed_per_l`` x litres removed above the goal inside its footprint, less
    ``overdig_per_l`` x litres dug below the goal profile, less ``stall`` for a stalled dig (true
    terrain, after settlement). ``terminated`` when the episode ends ``done`` (the map shows the
    trench within tolerance), ``no_dig`` or ``diverged``; ``truncated`` when the dig budget (or the
    episode's wall-clock limit) is spent. ``info``: ``planner_action`` (the planner's (k, alpha,
    d1) on the current map, None when it has no trenching dig), ``planner_fell_back``,
    ``map_removed_fraction``; after a dig ``dig`` (the row of the ``trench`` table: action, planned and
    dug litres, efficiency, outcome, failure, stall, predicted and measured wrist peaks),
    ``reward_terms``, ``action_used``, ``executed_cell`` and ``snapped_to_allowed``; at the end
    ``episode`` (:func:`~excavsim.loop.scenario.episode_summary` without its wall-clock times).
    The whole :class:`~excavsim.handoff.episode.EpisodeResult` is :attr:`result` once it ended.

    Seeding: ``reset(seed=s)`` runs the episode with seed ``s`` (the world's soil, sensor noise and
    scanner drift), so the same seed and actions give the same episode bit for bit; ``reset()``
    without a seed runs the spec's seed first, then seeds drawn from :attr:`np_random`.

    Args:
        spec, weights, fallback, window_margin_m, window_half_width_m, observer, robot_path, scene_path:
            as :class:`~excavsim.envs.core.DigCore`.
        normalize_action: the action in [-1, 1] (above) instead of the planner's units.
        render_mode: None (the default) or ``"rgb_array"``: :meth:`render` returns a frame of the
            world between digs from MuJoCo's offscreen renderer (:mod:`excavsim.envs.render`); to
            record whole episodes use ``observer=excavsim.record.TrenchRecorder(...)``.
        render_size: (width, height) of the frames [pixels].
    """

    core_class = DigCore
    env_id = "TrenchDig-v0"
    action_noun = "dig action"


def _episode_seed(env: gym.Env, seed: int | None) -> int:
    """The seed of the episode ``env.reset(seed=seed)`` starts: ``seed``; without one, the spec's
    on the first reset (which also seeds ``np_random`` with it), then draws from ``np_random``."""
    if seed is not None:
        check_seed(seed)
        gym.Env.reset(env, seed=seed)
        episode_seed = seed
    elif env._resets == 0:
        episode_seed = env.core.spec.seed
        gym.Env.reset(env, seed=episode_seed)
    else:
        gym.Env.reset(env)
        episode_seed = int(env.np_random.integers(0, 2**32))
    env._resets += 1
    return episode_seed


class PlannerPolicy:
    """The planner as a policy of :class:`TrenchDigEnv`: the planner's (k, alpha, d1) on the current
    map (``info["planner_action"]``), and the middle of the action space in a cycle where the planner
    has no trenching dig (there the environment digs the loop's fallback and does not use it).

    Through the environment it reproduces ``excavsim trench`` for the same spec and seed.

    Args:
        action_space: the environment's action space.
    """

    def __init__(self, action_space: gym.spaces.Box):
        self.default = ((action_space.low + action_space.high) / 2).astype(action_space.dtype)

    def __call__(self, observation, info: dict[str, Any]) -> np.ndarray:
        """The action for this cycle."""
        action = info.get("planner_action")
        return self.default.copy() if action is None else np.asarray(action, dtype=self.default.dtype)
