"""The cores' observation fields (:class:`~excavsim.envs.core.Field`) as Gymnasium spaces."""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from excavsim.envs.core import Field


def field_space(field: Field) -> gym.Space:
    """A ``Discrete`` space for a discrete field, else a ``Box`` of its shape, bounds and dtype."""
    if field.n is not None:
        return gym.spaces.Discrete(field.n)
    return gym.spaces.Box(low=np.full(field.shape, field.low, dtype=field.dtype),
                          high=np.full(field.shape, field.high, dtype=field.dtype), dtype=field.dtype)


def dict_space(fields: dict[str, Field]) -> gym.spaces.Dict:
    """The observation space of a core: a ``Dict`` of :func:`field_space` per field, in the core's order."""
    return gym.spaces.Dict({name: field_space(f) for name, f in fields.items()})
