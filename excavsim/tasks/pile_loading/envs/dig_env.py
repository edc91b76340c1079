"""``excavsim/LoadDig-v0``: loading from a pile in MuJoCo, one step per dig, the action the loading
planner's (Gymnasium).

:class:`LoadDigEnv` is the Gymnasium face of :class:`~excavsim.tasks.pile_loading.envs.core.LoadCore`;
:class:`LoadPlannerPolicy` is the loading planner used as a policy through it.
"""

from __future__ import annotations

from excavsim.envs.dig_env import DigStepEnv, PlannerPolicy
from excavsim.tasks.pile_loading.envs.core import LoadCore


class LoadDigEnv(DigStepEnv):
    """A loading episode (front loader or front shovel, a pile in a lane), one step per dig.

    See :class:`~excavsim.tasks.pile_loading.envs.core.LoadCore` for the rules (snapping to the planner's grid,
    the nearest feasible cell for an infeasible one, the reward's terms). Spaces:

    * action: ``Box(2,)`` float32 (k, alpha) from the planner grid's minima to its maxima [m, rad]
      (``Box(3,)`` (k, alpha, r) with ``parameterization: k_alpha_r`` in configs/pile_loading_planar.yaml); with
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
    ``episode`` (:func:`~excavsim.tasks.pile_loading.task.summary` without its wall time). The
    :class:`~excavsim.tasks.pile_loading.task.MujocoRun` is :attr:`result` once the episode ended.

    Seeding as every dig-level environment (:class:`~excavsim.envs.dig_env.DigStepEnv`): ``reset(seed=s)`` runs the episode with
    seed ``s`` (the soil, the scanner's noise and drift); ``reset()`` without a seed runs the spec's
    seed first, then seeds drawn from :attr:`np_random`.

    Args:
        spec, weights, observer: as :class:`~excavsim.tasks.pile_loading.envs.core.LoadCore`.
        normalize_action: the action in [-1, 1] instead of the planner's units.
        render_mode: None (the default) or ``"rgb_array"`` (a frame of the world between digs).
        render_size: (width, height) of the frames [pixels].
    """

    core_class = LoadCore
    env_id = "LoadDig-v0"
    action_noun = "loading action"

    def _world(self):
        task = self.core._task
        return None if task is None else task.world


class LoadPlannerPolicy(PlannerPolicy):
    """The loading planner as a policy of :class:`LoadDigEnv`: the planner's action on the current map
    (``info["planner_action"]``), the middle of the action space once the episode ended (the step
    that reports the end digs nothing). Through the environment it reproduces the plain loading episode.

    Args:
        action_space: the environment's action space (in the planner's units).
    """
