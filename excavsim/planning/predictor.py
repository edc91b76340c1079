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
    ``F (sin(rho + delta), -cos(rho + delta))``. A bucket takes the displaced soil in; the soil it
    holds bears on the wedge with a share that grows with its fill (§5.1.3: once scooped soil is
    captive, "the soil at the surface of the bucket acts as the cutting surface"), and what it
    sweeps beyond ``capacity_m3`` stays ahead of the blade and bears in full:
    ``Q = s h + f h (h / C) + max(v - C, 0)``, ``h = min(v, C)``, with ``f = 1`` (``fill_weighted``)
    the world's law (:func:`excavsim.world.kernels.load_surcharge_volume`, assumed share) and ``s``
    a constant share (0 by default; 0.3 was the nominal belief before the world's load bore on the
    wedge). (Simplified: the thesis' blade has no bucket; the pile ahead is spread uniformly over
    the wedge, as eq. 7 assumes.)

    Args:
        soil: the soil believed in; width_m: the bucket's width [m].
        surcharge_fraction: ``s``, a constant share of the swept volume bearing on the wedge while
            the bucket has room.
        capacity_m3: ``C``, the load the bucket holds before cut soil stays ahead of it [m^3]
            (``inf``: never, the blade-only form; the fill-weighted share is then 0).
        fill_weighted: whether the held soil bears with the share ``h / C`` (``f = 1``).
    """

    def __init__(self, soil: SoilParams, width_m: float, *, surcharge_fraction: float = 0.0,
                 capacity_m3: float = float("inf"), fill_weighted: bool = True):
        self.soil = soil
        self.width = float(width_m)
        self.surcharge_fraction = float(surcharge_fraction)
        self.fill = 1.0 if fill_weighted else 0.0
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
                "share": self.surcharge_fraction, "capacity": self.capacity, "fill": self.fill,
                "n_gamma": t.n_gamma, "n_c": t.n_c,
                "n_a": t.n_a, "denominator": t.denominator}

    def predict(self, depth: np.ndarray, rake: np.ndarray, volume: np.ndarray,
                context: DigContext | None = None) -> np.ndarray:
        depth = np.maximum(np.asarray(depth, dtype=float), 0.0)
        rk = np.clip(np.asarray(rake, dtype=float), self._rake_lo, self.table.rake_max)
        v = np.maximum(np.asarray(volume, dtype=float), 0.0)
        held = np.minimum(v, self.capacity)
        bearing = self.surcharge_fraction * held + self.fill * held * (held / self.capacity)
        vol = np.where(depth > 0, bearing + (v - held), 0.0)
        f = wedge_force(depth, rk, self.soil, self.width, surcharge_volume_m3=vol, table=self.table)
        a = rk + self.soil.delta
        return np.stack([f * np.sin(a), -f * np.cos(a)], axis=-1)
