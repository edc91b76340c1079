"""Force predictors: what the planner expects the soil to push back with along a dig.

The planner's force constraint (000_a3ca905d8c6d92bf.txt §5.3) takes any object with a ``predict``
method (:class:`ForcePredictor`); the nominal one is the wedge model (eq. 8) with the configured
soil, which the world's soil deliberately differs from. Learned predictors (issue #8) plug in here.
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np

from excavsim.config import SoilParams
from excavsim.world.wedge import WedgeTable, wedge_force

# Below this rake the wedge model leaves its domain (a blade slicing along itself): as in the world
# model, the factors are held at their value here.
MIN_RAKE = math.radians(5.0)


class ForcePredictor(Protocol):
    """Predicts the soil's force on the bucket at samples of a dig (vectorized)."""

    def predict(self, depth: np.ndarray, rake: np.ndarray, volume: np.ndarray) -> np.ndarray:
        """Force of the soil on the bucket in the arm plane.

        Args:
            depth: (...) depth of the cutting edge below the (mapped) surface [m], >= 0.
            rake: (...) rake (pitch) of the blade [rad].
            volume: (...) soil swept so far along the dig [m^3].

        Returns:
            (..., 2) force (F_x, F_z) on the bucket [N], x radial (away from the robot), z up.
        """
        ...


class WedgePredictor:
    """The nominal predictor: eq. 8 for a blade of the bucket's width dragged towards the robot.

    The magnitude is ``(gamma g d^2 N_gamma + c d N_c) w`` plus a surcharge of ``surcharge_fraction``
    of the swept volume (eq. 7 with the soil displaced by the tool), at ``pi/2 - rho - delta`` below
    the horizontal, pointing away from the robot: ``F (sin(rho + delta), -cos(rho + delta))``.
    """

    def __init__(self, soil: SoilParams, width_m: float, *, surcharge_fraction: float = 0.3):
        self.soil = soil
        self.width = float(width_m)
        self.surcharge_fraction = float(surcharge_fraction)
        self.table = WedgeTable.for_soil(soil)
        self._rake_lo = max(self.table.rake_min, MIN_RAKE)

    def predict(self, depth: np.ndarray, rake: np.ndarray, volume: np.ndarray) -> np.ndarray:
        depth = np.maximum(np.asarray(depth, dtype=float), 0.0)
        rk = np.clip(np.asarray(rake, dtype=float), self._rake_lo, self.table.rake_max)
        vol = np.where(depth > 0, self.surcharge_fraction * np.asarray(volume, dtype=float), 0.0)
        f = wedge_force(depth, rk, self.soil, self.width, surcharge_volume_m3=vol, table=self.table)
        a = rk + self.soil.delta
        return np.stack([f * np.sin(a), -f * np.cos(a)], axis=-1)
