"""``excavsim/TrenchDig-v0``: Singh's trenching action as the action, one step per dig (Gymnasium).

:class:`TrenchDigEnv` is the Gymnasium face of :class:`~excavsim.tasks.trench.envs.core.DigCore` (the
episode loop of ``excavsim trench`` with the agent choosing each trenching action); the planner used as a
policy through it is :class:`~excavsim.envs.dig_env.PlannerPolicy`.
"""

from __future__ import annotations

from excavsim.envs.dig_env import DigStepEnv, PlannerPolicy
from excavsim.tasks.trench.envs.core import DigCore

__all__ = ["PlannerPolicy", "TrenchDigEnv"]


class TrenchDigEnv(DigStepEnv):
    """A trenching episode, one step per dig: the action is (k, alpha, d1) [m, rad, m].

    See :class:`~excavsim.tasks.trench.envs.core.DigCore` for the rules (snapping to the planner's grid, the
    nearest allowed cell for an infeasible one, the fallback). Spaces:

    * action: ``Box(3,)`` float32 from the planner grid's (k_min, alpha_min, d1_min) to its maxima
      (in metres and radians, deliberately: the planner's units); with ``normalize_action=True``
      ``Box(3,)`` in [-1, 1], mapped linearly onto that box (-1 the minima, 1 the maxima);
    * observation: ``Dict`` of ``elevation``, ``goal_mask``, ``goal_depth`` (lateral x radial
      float32 grids around the goal, from the scanned map), ``ft`` (the last dig's peak and mean F/T
      force in the soil [N]), ``outcome`` (``Discrete``, an index of
      :data:`~excavsim.tasks.trench.envs.core.OUTCOMES`) and ``digs_left`` (``Discrete``).

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
            as :class:`~excavsim.tasks.trench.envs.core.DigCore`.
        normalize_action: the action in [-1, 1] (above) instead of the planner's units.
        render_mode: None (the default) or ``"rgb_array"``: :meth:`render` returns a frame of the
            world between digs from MuJoCo's offscreen renderer (:mod:`excavsim.envs.render`); to
            record whole episodes use ``observer=excavsim.record.TrenchRecorder(...)``.
        render_size: (width, height) of the frames [pixels].
    """

    core_class = DigCore
    env_id = "TrenchDig-v0"
    action_noun = "dig action"
