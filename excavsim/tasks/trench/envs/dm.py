"""The trench's dig level with a dm_env face: :class:`DmTrenchDig` (the conventions of :mod:`excavsim.envs.dm`).

The joint level's dm_env face is the platform's :class:`~excavsim.envs.dm.DmJoint` (``DmJoint(spec)`` digs
the spec's trench).
"""

from __future__ import annotations

from excavsim.envs.dm import DmFace
from excavsim.tasks.trench.envs.core import DigCore


class DmTrenchDig(DmFace):
    """``TrenchDig`` with a dm_env face: one step per dig, the action (k, alpha, d1) [m, rad, m]
    (see :class:`~excavsim.tasks.trench.envs.core.DigCore` and
    :class:`~excavsim.tasks.trench.envs.dig_env.TrenchDigEnv`).

    Args:
        spec: the episode; seed: the first episode's seed (see :mod:`excavsim.envs.dm`); the rest as
            :class:`~excavsim.tasks.trench.envs.core.DigCore`.
    """

    _core_class = DigCore
