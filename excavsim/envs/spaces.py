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


def space_table(fields: dict[str, Field]) -> str:
    """A Markdown table of a core's observation fields: name, shape, dtype, bounds (or values) and
    meaning; docs/environments.md's tables are this function's output::

        python -c "from excavsim.envs.spaces import space_table; from excavsim.envs import JointCore; \\
                   print(space_table(JointCore().fields))"
    """
    lines = ["| entry | shape | dtype | bounds | meaning |", "|---|---|---|---|---|"]
    for name, f in fields.items():
        bounds = f"0 ... {f.n - 1} (Discrete)" if f.n is not None else f"[{f.low:g}, {f.high:g}]"
        lines.append(f"| `{name}` | {tuple(f.shape)} | {f.dtype if f.n is None else 'int64'} | {bounds} | {f.doc} |")
    return "\n".join(lines)
