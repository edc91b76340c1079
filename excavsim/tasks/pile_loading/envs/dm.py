"""Loading from a pile with a dm_env face: :class:`DmLoadDig` (the conventions of :mod:`excavsim.envs.dm`)."""

from __future__ import annotations

from excavsim.envs.dm import DmFace
from excavsim.tasks.pile_loading.envs.core import LoadCore


class DmLoadDig(DmFace):
    """``LoadDig`` with a dm_env face: one step per dig of loading from a pile, the action the loading
    planner's (k, alpha) [m, rad] (see :class:`~excavsim.tasks.pile_loading.envs.core.LoadCore` and
    :class:`~excavsim.tasks.pile_loading.envs.dig_env.LoadDigEnv`).

    Args:
        spec: the episode (task pile_loading); seed: the first episode's seed (see :mod:`excavsim.envs.dm`);
            the rest as :class:`~excavsim.tasks.pile_loading.envs.core.LoadCore`.
    """

    _core_class = LoadCore
