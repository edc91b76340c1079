"""The environments' dm_env face: :class:`DmFace` around any core, :class:`DmJoint` at the joint level.

The same cores as the Gymnasium environments (:mod:`excavsim.envs.core`), with dm_env's conventions (each
task's dig-level faces subclass :class:`DmFace` in the task's folder): ``reset()`` returns a ``FIRST`` time step; ``step`` on a fresh environment or after a
``LAST`` one starts an episode (the action is ignored); a terminated episode ends with discount 0,
a truncated one (the dig budget, the time limit) with discount 1. Observations are dicts of numpy
arrays with :meth:`observation_spec` as the Gymnasium faces' spaces; a discrete entry is a
``DiscreteArray``.

Seeding: episode ``n`` (from 0) of an environment built with ``seed=s`` runs seed ``s + n`` (modulo
2**32); ``seed`` None starts at the spec's seed. The same ``seed`` and actions repeat every episode
bit for bit.
"""

from __future__ import annotations

from typing import Any

import dm_env
import numpy as np
from dm_env import specs

from excavsim.envs.core import MAX_SEED, Field, check_seed
from excavsim.envs.joint_core import JointCore


def field_spec(name: str, field: Field) -> specs.Array:
    """A dm_env spec for one observation field: ``DiscreteArray`` or ``BoundedArray``."""
    if field.n is not None:
        return specs.DiscreteArray(field.n, dtype=field.dtype, name=name)
    return specs.BoundedArray(field.shape, field.dtype, np.full(field.shape, field.low, dtype=field.dtype),
                              np.full(field.shape, field.high, dtype=field.dtype), name=name)


class DmFace(dm_env.Environment):
    """dm_env's episode protocol around a core with ``reset(seed)``, ``step(action)`` and ``close()`` (a
    subclass names it: :attr:`_core_class`)."""

    _core_class: type

    def __init__(self, spec=None, *, seed: int | None = None, **kwargs: Any):
        self.core = self._core_class(spec, **kwargs)
        self._seed = self.core.spec.seed if seed is None else check_seed(seed)
        self._episodes = 0
        self._running = False
        self._obs_spec = {name: field_spec(name, f) for name, f in self.core.fields.items()}
        self._action_spec = specs.BoundedArray(self.core.action_low.shape, np.float64, self.core.action_low,
                                               self.core.action_high, name="action")

    def reset(self) -> dm_env.TimeStep:
        """Start the next episode (seed ``seed + n``); a ``FIRST`` time step."""
        seed = (self._seed + self._episodes) % (MAX_SEED + 1)
        self._episodes += 1
        obs, _ = self.core.reset(seed)
        self._running = True
        return dm_env.restart(obs)

    def step(self, action) -> dm_env.TimeStep:
        """Act; a ``MID`` or ``LAST`` time step, or a ``FIRST`` one when no episode was running."""
        if not self._running:
            return self.reset()
        obs, reward, terminated, truncated, _ = self.core.step(action)
        if terminated:
            self._running = False
            return dm_env.termination(reward, obs)
        if truncated:
            self._running = False
            return dm_env.truncation(reward, obs)
        return dm_env.transition(reward, obs)

    def observation_spec(self) -> dict[str, specs.Array]:
        """The observation's entries (see the Gymnasium faces' observation spaces)."""
        return dict(self._obs_spec)

    def action_spec(self) -> specs.BoundedArray:
        """The action: float64 within the core's bounds."""
        return self._action_spec

    def reward_spec(self) -> specs.Array:
        """A float64 scalar."""
        return specs.Array((), np.float64, name="reward")

    def close(self) -> None:
        """Abandon the running episode (closing twice is fine)."""
        self.core.close()

    def __del__(self):
        core = getattr(self, "core", None)  # as the Gymnasium faces: a dropped environment ends its episode
        if core is not None:
            core.close()


class DmJoint(DmFace):
    """The joint level with a dm_env face, any machine and goal: one step per control period, the action
    four set-point rates in [-1, 1] (see :class:`~excavsim.envs.joint_core.JointCore` and
    :class:`~excavsim.envs.joint_env.JointEnv`): ``DmJoint(spec)`` is the default task's goal (digging the
    spec's trench), ``DmJoint(goal="region")`` ``ExcavatorJoint``'s.

    Args:
        spec: the world; seed: the first episode's seed (see the module docstring); the rest as
            :class:`~excavsim.envs.joint_core.JointCore`.
    """

    _core_class = JointCore
