"""The planner's nominal force predictor: the wedge model (Singh 1995 eq. 8).

It implements :class:`~excavsim.handoff.forces.ForcePredictor` with the configured soil's wedge
model; learned predictors (:mod:`excavsim.learning`) implement the same protocol.
"""

from __future__ import annotations

import numpy as np

from excavsim.config import SoilParams
from excavsim.errors import SoilModelError
from excavsim.handoff.forces import DigContext
from excavsim.mechanics.wedge import G_M_S2, MIN_RAKE_RAD, WedgeTable, wedge_force


class WedgePredictor:
    """The nominal predictor: eq. 8 for a blade of the bucket's width dragged towards the robot.

    The magnitude is ``(gamma g d^2 N_gamma + c d N_c) w`` plus the weight of a surcharge over the
    denominator of eq. 5 (eq. 7, with the soil displaced by the tool as the surcharge, Fig. 57), at
    ``pi/2 - rho - delta`` below the horizontal, pointing away from the robot:
    ``F (sin(rho + delta), -cos(rho + delta))``. A bucket takes the displaced soil in, so only a
    share ``surcharge_fraction`` of the swept volume ``v`` bears on the wedge while the bucket has
    room; what it sweeps beyond ``capacity_m3`` stays ahead of the blade and bears in full:
    ``Q = s min(v, C) + max(v - C, 0)``. (Simplified: the thesis' blade has no bucket; the share
    ``s`` is assumed, and the pile ahead is spread uniformly over the wedge, as eq. 7 assumes.)

    Args:
        soil: the soil believed in; width_m: the bucket's width [m].
        surcharge_fraction: ``s``, the share of the swept volume bearing on the wedge while the
            bucket has room.
        capacity_m3: ``C``, the load the bucket holds before cut soil stays ahead of it [m^3]
            (``inf``: never, the blade-only form).
    """

    def __init__(self, soil: SoilParams, width_m: float, *, surcharge_fraction: float = 0.3,
                 capacity_m3: float = float("inf")):
        self.soil = soil
        self.width = float(width_m)
        self.surcharge_fraction = float(surcharge_fraction)
        self.capacity = float(capacity_m3)
        if not self.capacity > 0:
            raise SoilModelError(f"capacity_m3 must be positive (inf: no limit); given {capacity_m3!r}")
        self.table = WedgeTable.for_soil(soil)
        self._rake_lo = max(self.table.rake_min, MIN_RAKE_RAD)

    def kernel_params(self) -> dict[str, float | np.ndarray]:
        """The numbers of :meth:`predict`, for the compiled planner kernel (:mod:`excavsim.planning.kernel`).

        A predictor that has this method promises that its forces are this model's with these numbers;
        the kernel computes them with the same arithmetic as :meth:`predict`.
        """
        soil, t = self.soil, self.table
        return {"rake0": float(t.rake[0]), "rake_step": float(t.rake_step), "rake_lo": float(self._rake_lo),
                "rake_hi": float(t.rake_max), "delta": float(soil.delta), "gamma_g": soil.density_kg_m3 * G_M_S2,
                "cohesion": float(soil.cohesion_pa), "adhesion": float(soil.adhesion_pa), "width": self.width,
                "share": self.surcharge_fraction, "capacity": self.capacity, "n_gamma": t.n_gamma, "n_c": t.n_c,
                "n_a": t.n_a, "denominator": t.denominator}

    def predict(self, depth: np.ndarray, rake: np.ndarray, volume: np.ndarray,
                context: DigContext | None = None) -> np.ndarray:
        depth = np.maximum(np.asarray(depth, dtype=float), 0.0)
        rk = np.clip(np.asarray(rake, dtype=float), self._rake_lo, self.table.rake_max)
        v = np.maximum(np.asarray(volume, dtype=float), 0.0)
        held = np.minimum(v, self.capacity)
        vol = np.where(depth > 0, self.surcharge_fraction * held + (v - held), 0.0)
        f = wedge_force(depth, rk, self.soil, self.width, surcharge_volume_m3=vol, table=self.table)
        a = rk + self.soil.delta
        return np.stack([f * np.sin(a), -f * np.cos(a)], axis=-1)
