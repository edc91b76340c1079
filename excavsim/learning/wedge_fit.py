"""The wedge model as a learned predictor: soil parameters fitted to measured forces (§5.2.1, §5.2.4.1)."""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import least_squares

from excavsim.config import SoilParams
from excavsim.learning.encoding import Samples
from excavsim.learning.model import ForceModel, check_forces
from excavsim.mechanics.wedge import G_M_S2, MIN_RAKE_RAD, critical_beta, n_factors, wedge_denominator

# Bounds of (c [Pa], phi [rad], delta [rad], gamma [N/m^3]) for the fit.
WEDGE_BOUNDS = ((0.0, math.radians(10.0), math.radians(5.0), 5.0e3),
                (1.0e5, math.radians(45.0), math.radians(45.0), 4.0e4))
_WEDGE_UNITS = np.array([1.0e3, 1.0, 1.0, 1.0e4])  # fit in kPa, rad, rad, 10 kN/m^3


class WedgeModel(ForceModel):
    """The Fundamental Equation of Earthmoving (eq. 8) as a predictor of the wrist sensor's reading.

    The blade force ``F = (gamma d^2 N_gamma + c d N_c) w + gamma s v / D`` (depth ``d = l_1`` at
    the tip, surcharge of the fraction ``s`` of the swept volume ``v``, eq. 7) acts along
    ``(-sin delta, -cos delta)`` in the tip frame; the load in the bucket adds its weight
    ``gamma v``. With ``fit_params`` the soil's ``c, phi, delta, gamma`` are found by bounded
    nonlinear least squares (scipy's trust-region reflective method, soft-L1 loss against the
    sawtooth peaks) from several starts: the thesis searched a 20^4 grid for days (§5.2.4.1) and
    found many near-equal minima, hence the restarts. Without it the soil's nominal values are used.

    Args:
        soil: the nominal soil (and the first start of the fit).
        width: bucket width [m].
        fit_params: fit ``c, phi, delta, gamma`` to the data (else ``fit`` only stores the data).
        surcharge_fraction: ``s``, as the planner's nominal predictor.
        starts: starting points of the fit (the nominal soil and random ones).
        seed: seeds the random starts.
    """

    def __init__(self, soil: SoilParams, width: float, *, fit_params: bool = True, surcharge_fraction: float = 0.3,
                 starts: int = 4, seed: int = 0):
        self.name = "wedge model (fitted)" if fit_params else "wedge model (nominal)"
        self.width = float(width)
        self.fit_params = fit_params
        self.surcharge_fraction = float(surcharge_fraction)
        self.starts = int(starts)
        self.seed = seed
        self.theta = np.array([soil.cohesion_pa, soil.phi, soil.delta, soil.density_kg_m3 * G_M_S2])
        self._data: tuple[np.ndarray, np.ndarray] | None = None
        self.cost = math.nan

    @property
    def fitted(self) -> bool:
        return True  # the nominal soil predicts before any data

    @property
    def nbytes(self) -> int:
        return int(self.theta.nbytes)

    def _inputs(self, samples: Samples) -> np.ndarray:
        return np.stack([np.asarray(samples[c], dtype=float) for c in ("l1", "rake", "v")], axis=-1)

    def forces(self, theta: np.ndarray, x: np.ndarray) -> np.ndarray:
        """Tip-frame forces (..., 2) for parameters ``theta`` = (c, phi, delta, gamma) and inputs (..., 3)."""
        c, phi, delta, gamma = theta
        d, rho, v = np.maximum(x[..., 0], 0.0), x[..., 1], np.maximum(x[..., 2], 0.0)
        rk = np.clip(rho, MIN_RAKE_RAD, math.pi - phi - delta - math.radians(1.0))
        beta = critical_beta(rk, phi, delta)
        n_gamma, n_c, _, _ = n_factors(rk, beta, phi, delta)
        big_d = wedge_denominator(rk, beta, phi, delta)
        blade = (gamma * d**2 * n_gamma + c * d * n_c) * self.width + gamma * self.surcharge_fraction * v / big_d
        blade = np.where(d > 0, blade, 0.0)
        load = gamma * v  # the carried soil's weight, seen by the sensor
        return np.stack([-blade * math.sin(delta) + load * np.sin(rho),
                         -blade * math.cos(delta) - load * np.cos(rho)], axis=-1)

    def fit(self, samples: Samples, forces: np.ndarray) -> WedgeModel:
        return self.fit_inputs(self._inputs(samples), check_forces(forces))

    def fit_inputs(self, x: np.ndarray, y: np.ndarray, *, starts: int | None = None) -> WedgeModel:
        self._data = (x, y)
        if not self.fit_params:
            return self
        lo, hi = (np.array(b) / _WEDGE_UNITS for b in WEDGE_BOUNDS)
        rng = np.random.default_rng(self.seed)
        n_starts = self.starts if starts is None else starts
        firsts = [np.clip(self.theta / _WEDGE_UNITS, lo, hi)] + [rng.uniform(lo, hi) for _ in range(n_starts - 1)]

        def residuals(u: np.ndarray) -> np.ndarray:
            return (self.forces(u * _WEDGE_UNITS, x) - y).ravel()

        best = None
        for u0 in firsts:
            res = least_squares(residuals, u0, bounds=(lo, hi), loss="soft_l1", f_scale=100.0, x_scale="jac")
            if best is None or res.cost < best.cost:
                best = res
        self.theta = best.x * _WEDGE_UNITS
        self.cost = float(best.cost)
        return self

    def update(self, samples: Samples, forces: np.ndarray) -> WedgeModel:
        """Refit on everything seen, from the current parameters (the thesis: "complete retraining")."""
        x, y = self._inputs(samples), check_forces(forces)
        if self._data is not None:
            x, y = np.concatenate([self._data[0], x]), np.concatenate([self._data[1], y])
        return self.fit_inputs(x, y, starts=1)

    def predict(self, samples: Samples) -> np.ndarray:
        return self.forces(self.theta, self._inputs(samples))

    def describe(self) -> str:
        c, phi, delta, gamma = self.theta
        return (f"c {c / 1e3:.2f} kPa, phi {math.degrees(phi):.1f} deg, delta {math.degrees(delta):.1f} deg, "
                f"gamma {gamma / 1e3:.2f} kN/m^3")
