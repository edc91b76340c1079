"""What every world of excavsim is to the platform: one protocol over the trenching and the loading worlds.

:class:`~excavsim.world.simulation.Simulation` (the T3 over its soil box) and
the loading world (a front loader or a front shovel over its lane, a task's own world)
are both MuJoCo and the heightfield soil stepped together at the control rate. :class:`World` is
what they share, so that the pieces of an episode around the machine (scanning the terrain into a
map, settling the soil after a dig, the volume account, the observers' step hooks, the watchdog's
``Diverged``) are written once for every task: the scanner reads ``model`` and ``soil.grid``, the
account ``volumes()``, the observers ``step_hooks``. How a step is commanded differs by machine
(the T3's servo rates, a loading machine's joint set-points) and stays the machine's.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol, runtime_checkable

import mujoco
import numpy as np

from excavsim.world.soil import SoilModel, Volumes


@runtime_checkable
class World(Protocol):
    """A machine over its soil, stepped at the control rate (see the module docstring).

    Attributes:
        model, data: the compiled MuJoCo model and its state.
        soil: the heightfield soil (its grid is what the scanner sees).
        control_dt: one control step [s].
        step_hooks: called with the world after every control step (recorders, accounts); read-only use.
    """

    model: mujoco.MjModel
    data: mujoco.MjData
    soil: SoilModel
    control_dt: float
    step_hooks: list[Callable[[Any], None]]

    @property
    def time(self) -> float:
        """Simulated time [s]."""

    def joint_angles(self) -> np.ndarray:
        """The joint encoders, in the machine's joint order [rad or m]."""

    def step(self, command: np.ndarray) -> Any:
        """One control step with the machine's command (raises ``Diverged`` when the physics broke)."""

    def settle_soil(self) -> None:
        """Settle the whole terrain now (after a dig or a dump)."""

    def volumes(self) -> Volumes:
        """Privileged truth: soil on the ground, in the bucket and in spoil [m^3]."""
