"""Loading from a pile's environment: what the task contributes to :mod:`excavsim.envs` (its plug-in's
``environments``).

``excavsim/LoadDig-v0`` (:class:`~excavsim.tasks.pile_loading.envs.dig_env.LoadDigEnv` over
:class:`~excavsim.tasks.pile_loading.envs.core.LoadCore`): loading from a pile in MuJoCo, one step per dig,
the action the loading planner's (k, alpha); the loading planner as a policy is
:class:`~excavsim.tasks.pile_loading.envs.dig_env.LoadPlannerPolicy`, the dm_env face
:class:`~excavsim.tasks.pile_loading.envs.dm.DmLoadDig`. The id is declared in the task's plug-in
(:mod:`excavsim.tasks.pile_loading.plugin`) and named here too.
"""

from __future__ import annotations

from excavsim.tasks.pile_loading.plugin import LOAD_DIG_ENV_ID

__all__ = ["LOAD_DIG_ENV_ID"]
