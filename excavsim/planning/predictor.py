"""The planner's nominal force predictor: the wedge model (000_a3ca905d8c6d92bf.txt eq. 8).

It implements :class:`~excavsim.handoff.forces.ForcePredictor` with the configured soil's wedge
model; learned predictors (:mod:`excavsim.learning`) implement the same protocol.
"""

from __future__ import annotations

import numpy as np

from excavsim.config import SoilParams
from excavsim.handoff.forces import DigContext
from excavsim.mechanics.wedge import MIN_RAKE_RAD, WedgeTable, wedge_force


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
        self._rake_lo = max(self.table.rake_min, MIN_RAKE_RAD)

    def predict(self, depth: np.ndarray, rake: np.ndarray, volume: np.ndarray,
                context: DigContext | None = None) -> np.ndarray:
        depth = np.maximum(np.asarray(depth, dtype=float), 0.0)
        rk = np.clip(np.asarray(rake, dtype=float), self._rake_lo, self.table.rake_max)
        vol = np.where(depth > 0, self.surcharge_fraction * np.asarray(volume, dtype=float), 0.0)
        f = wedge_force(depth, rk, self.soil, self.width, surcharge_volume_m3=vol, table=self.table)
        a = rk + self.soil.delta
        return np.stack([f * np.sin(a), -f * np.cos(a)], axis=-1)
