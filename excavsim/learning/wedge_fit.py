"""The wedge model as a learned predictor: soil parameters fitted to measured forces (§5.2.1, §5.2.4.1)."""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import least_squares

from excavsim.config import SoilParams
from excavsim.errors import SoilModelError
from excavsim.learning.encoding import Samples
from excavsim.learning.model import ForceModel, check_forces
from excavsim.mechanics.wedge import G_M_S2, MIN_RAKE_RAD, critical_beta, n_factors, wedge_denominator
from excavsim.mechanics.wedge_inertia import acceleration_factor

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


# -- the wedge model of a dig record, for calibrating a soil (excavsim calibrate) ------------------

PROBE_M = 0.05  # the depth the blade faces is read this far ahead of the tip [m]
AHEAD_COLUMNS = ("l1", "l2", "l3", "l4", "l5")
AHEAD_SPACING_M = 0.1  # of the l_i columns (learning.encoding.AHEAD_SPACING_M)
_N_WEDGE_SAMPLES = 24  # points along the failure wedge at which the surcharge ahead is summed
# The soil enters the bucket this far ahead of the tip's path [m] (measured against the world's load
# over 12 records of 3 quiet digs, 3 soils x seeds 0-3: the load's RMS error lower than without a lead
# in 9 of them, 0.25-0.96 l against 0.31-1.06 l; a lead of 2.5 cm is worse than 1.25 cm in 11).
LEAD_M = 0.0125
RATE_REFERENCE_M_S = 0.01  # the advance speed at which a preset's cohesion holds (scene.yaml, assumed)


def load_profile(swept_m3: np.ndarray, dig: np.ndarray, measured_m3: dict[int, float] | None = None, *,
                 tip_depth_m: np.ndarray | None = None, width_m: float = 0.0, lead_m: float = LEAD_M) -> np.ndarray:
    """The soil in the bucket along each dig (n,) [m^3]: the swept volume ``v``, plus the soil above
    the tip's level over ``lead_m`` ahead of it (``w lead_m l_1``, with ``tip_depth_m`` = ``l_1``),
    scaled, per dig, to the volume the scans measured the dig to remove (the map before less the map
    after, around the dig), where it is known; else that volume itself.

    The swept volume is the tip's path over the mapped surface: it misses what the bucket's full
    width and the touch-down cut (measured: 13-20 % less than the load), while the scans see the
    soil that left the ground within about 2 % (3-4 digs of the testbed sand). The soil is cut a
    little ahead of the tip's path (the touch-down's plunge has cut some before the dig's first
    sample); the lead puts that share where it is cut instead of spreading it over the dig.
    """
    v = np.maximum(np.asarray(swept_m3, dtype=float), 0.0)
    if tip_depth_m is not None:
        v = v + width_m * lead_m * np.maximum(np.asarray(tip_depth_m, dtype=float), 0.0)
    out = v.copy()
    for k, vol in (measured_m3 or {}).items():
        m = dig == k
        top = float(v[m].max()) if m.any() else 0.0
        if top > 0 and np.isfinite(vol) and vol > 0:
            out[m] = v[m] * (vol / top)
    return out


class RecordWedge:
    """The wedge model (eq. 8) of what the wrist sensor reads along a dig, the forward model of a
    calibration (§5.2.3.1: the soil's ``c, phi, delta, gamma`` fitted to measured forces).

    Per F/T sample (tip frame, soil on the bucket, as :mod:`excavsim.sensing.ft` reports it)::

        F = F_b (-sin delta, -cos delta) + gamma V (sin rho, -cos rho)
        F_b = (gamma d^2 N_gamma + c d N_c) w + gamma (V_a + s V) / D + (gamma / g) u^2 d N_acc w
                                                                            (d > 0, else 0)

    eq. 8 with eq. 7's surcharge written as its weight over eq. 5's denominator ``D`` (``q d (cot
    rho + cot beta) w`` = the surcharge's weight), the inertial term of the dynamic earthmoving
    equation (McKyes 1985, :mod:`excavsim.mechanics.wedge_inertia`: the force that accelerates the
    soil entering the wedge at the blade's advance ``u``, ``N_acc`` at beta*), and the load ``V``'s
    weight. The inputs are the mind's, from the record:

    * ``d``: the depth of soil the blade faces, the scanned surface ``PROBE_M`` ahead of the tip
      less the tip's height (interpolated in the ``l_i`` columns): the failure wedge starts at the
      blade, not under the tip;
    * ``V_a``: the soil above that level on the wedge ahead, ``w`` times the integral of
      ``max(l(s) - d, 0)`` over the wedge's length ``d (cot rho + cot beta)`` (the ``l_i``
      profile, held at ``l5`` beyond it: the wall of the last dig, a heap) -- eq. 7's displaced
      soil lying on the wedge;
    * ``V``: the load (:func:`load_profile`); a share ``s`` of it may be set to ride on the wedge as
      surcharge (default 0: the load is in the bucket, not on the wedge; the world's wedge carries
      only the soil heaped on it);
    * ``u``: the tip's horizontal advance towards the arm's base (:func:`advance_speed`, from the
      encoders' poses in the record);
    * ``rho``: the rake, held at ``MIN_RAKE_RAD`` below it (the blade slices along itself there).

    The failure cycle (Figs. 53-54): with ``brittleness`` ``I_B`` > 0 the blade force is the cycle's
    mean, ``(1 - I_B / 2)`` times the force above. After each failure the force drops by the share
    ``I_B`` and climbs back, linearly in the edge's advance, as the next wedge takes up load, so it
    runs from ``(1 - I_B)`` of eq. 8's failure force to it: eq. 8 is the crest (the force just before
    failure, §5.1.2) and a saw-tooth's samples average its midpoint. ``I_B`` is the soil's (Bishop's
    brittleness index), stated by the user, not fitted: it scales the blade force as c and phi do,
    so the record cannot tell it from them. Simplified: the cycle's phase is not modelled (a sample
    is predicted by the mean; the drop within a cycle is left in the residuals), nor the lag while
    the cut deepens faster than the cycle rebuilds; ``I_B = 0`` is eq. 8 itself (a quiet record's
    wedge has no drops).

    The rate effect on cohesion: with ``rate_per_decade`` ``a`` > 0 the cohesion acts as
    ``c (1 + a log10(u / u_ref))`` while the edge advances faster than ``u_ref`` (a clay's undrained
    strength rises about 10 % per tenfold strain rate, Kulhawy & Mayne 1990); ``c`` is then the
    strength at ``u_ref``, as a soil preset states it (the world's ``truth.cohesion_rate_per_decade``
    and ``rate_reference_speed_m_s``). Like ``I_B`` it is stated, not fitted; without it (``a = 0``)
    the fitted ``c`` is the strength at the record's digging rate.

    Its simplifications: no adhesion term (the world's is zero for every preset); the bearing of the bucket's
    bottom at touch-down and the arm's inertia are left as residuals (they show in the first
    samples of a dig); plane strain across the whole width.

    Args:
        width: bucket width [m].
        surcharge_fraction: ``s`` [-].
        probe_m: where the depth is read ahead of the tip [m].
        brittleness: ``I_B`` in [0, 1) [-], the share of the failure force lost at each failure.
        rate_per_decade: ``a`` >= 0 [-], the cohesion's rise per tenfold advance speed above
            ``rate_reference_m_s`` [m/s].
        load_capacity_m3: ``C``, the heaped capacity of the world's load surcharge: the load ``V``
            bears on the wedge with the share ``min(V / C, 1)`` (Singh 1995 eq. 7, Fig. 57;
            :func:`excavsim.world.kernels.load_surcharge_volume`); ``inf``: not at all [m^3].
    """

    def __init__(self, width: float, *, surcharge_fraction: float = 0.0, probe_m: float = PROBE_M,
                 brittleness: float = 0.0, rate_per_decade: float = 0.0,
                 rate_reference_m_s: float = RATE_REFERENCE_M_S, load_capacity_m3: float = math.inf):
        if not load_capacity_m3 > 0:
            raise SoilModelError(f"load_capacity_m3 must be positive (inf: no load surcharge); given "
                                 f"{load_capacity_m3!r}")
        self.load_capacity_m3 = float(load_capacity_m3)
        if not 0.0 <= brittleness < 1.0:
            raise SoilModelError(f"brittleness must be in [0, 1); given {brittleness!r}")
        if not (rate_per_decade >= 0.0 and rate_reference_m_s > 0.0):
            raise SoilModelError(f"rate_per_decade must be >= 0 and rate_reference_m_s > 0; given {rate_per_decade!r}, "
                             f"{rate_reference_m_s!r}")
        self.rate_per_decade = float(rate_per_decade)
        self.rate_reference_m_s = float(rate_reference_m_s)
        self.width = float(width)
        self.surcharge_fraction = float(surcharge_fraction)
        self.probe_m = float(probe_m)
        self.brittleness = float(brittleness)

    @staticmethod
    def inputs(samples: Samples, load_m3: np.ndarray, advance_m_s: np.ndarray | None = None) -> np.ndarray:
        """The model's inputs (n, 8): ``l1..l5`` [m], rake [rad], load [m^3], the advance speed
        ``u`` [m/s] (zeros without ``advance_m_s``: the static model)."""
        cols = [np.asarray(samples[c], dtype=float) for c in AHEAD_COLUMNS]
        cols += [np.asarray(samples["rake"], dtype=float), np.asarray(load_m3, dtype=float)]
        u = np.zeros_like(cols[0]) if advance_m_s is None else np.asarray(advance_m_s, dtype=float)
        return np.stack(cols + [u], axis=-1)

    def depth(self, x: np.ndarray) -> np.ndarray:
        """The depth the blade faces (n,) [m]."""
        lp = np.maximum(x[:, :5], 0.0)
        u = self.probe_m / AHEAD_SPACING_M
        i = min(int(u), 3)
        return lp[:, i] + (u - i) * (lp[:, i + 1] - lp[:, i])

    def forces(self, theta: np.ndarray, x: np.ndarray) -> np.ndarray:
        """Tip-frame forces (n, 2) [N] for ``theta`` = (c [Pa], phi, delta [rad], gamma [N/m^3])."""
        c, phi, delta, gamma = (float(t) for t in theta)
        lp = np.maximum(x[:, :5], 0.0)
        rho, vol = x[:, 5], np.maximum(x[:, 6], 0.0)
        u = np.maximum(x[:, 7], 0.0)
        d = self.depth(x)
        rk = np.clip(rho, MIN_RAKE_RAD, math.pi - phi - delta - math.radians(1.0))
        beta = critical_beta(rk, phi, delta)
        n_gamma, n_c, _, _ = n_factors(rk, beta, phi, delta)
        big_d = wedge_denominator(rk, beta, phi, delta)
        n_acc = acceleration_factor(rk, beta, phi, delta)
        length = d * (1.0 / np.tan(rk) + 1.0 / np.tan(beta))
        s = (np.arange(_N_WEDGE_SAMPLES) + 0.5) / _N_WEDGE_SAMPLES * length[:, None]
        j = np.clip((s / AHEAD_SPACING_M).astype(int), 0, len(AHEAD_COLUMNS) - 2)
        frac = np.minimum(s / AHEAD_SPACING_M - j, 1.0)  # beyond l5 the surface is held at l5
        rows = np.arange(len(x))[:, None]
        prof = lp[rows, j] + frac * (lp[rows, j + 1] - lp[rows, j])
        ahead = self.width * np.maximum(prof - d[:, None], 0.0).mean(axis=1) * length
        bearing_load = vol * np.minimum(vol / self.load_capacity_m3, 1.0)
        surcharge = gamma * (ahead + self.surcharge_fraction * vol + bearing_load) / big_d
        inertia = np.where(np.isfinite(n_acc), gamma / G_M_S2 * u**2 * d * n_acc * self.width, 0.0)
        rate = 1.0 + self.rate_per_decade * np.log10(np.maximum(u, self.rate_reference_m_s) / self.rate_reference_m_s)
        blade = (gamma * d**2 * n_gamma + rate * c * d * n_c) * self.width + surcharge + inertia
        blade = np.where(d > 0, blade, 0.0) * (1.0 - 0.5 * self.brittleness)  # the failure cycle's mean
        load = gamma * vol
        return np.stack([-blade * math.sin(delta) + load * np.sin(rho),
                         -blade * math.cos(delta) - load * np.cos(rho)], axis=-1)

    def fit(self, x: np.ndarray, y: np.ndarray, start: np.ndarray, *, starts: int = 4, seed: int = 0,
            loss: str = "linear", fixed: dict[int, float] | None = None) -> tuple[np.ndarray, np.ndarray, float]:
        """``c, phi, delta, gamma`` by bounded nonlinear least squares (``WEDGE_BOUNDS``) from ``start``
        and ``starts - 1`` random points; returns them, their standard errors (Jacobian at the optimum
        and the residual variance; 0 for a held parameter) and the RMS residual [N].

        ``fixed``: parameters held at given values, by index into ``(c, phi, delta, gamma)`` (in
        their units: Pa, rad, rad, N/m^3), the rest fitted: a soil engineer's knowledge the record
        lacks (a sand is cohesionless: c = 0 removes the c-phi valley of §5.2.4.1)."""
        lo, hi = (np.array(b) / _WEDGE_UNITS for b in WEDGE_BOUNDS)
        held = {int(i): float(v) / _WEDGE_UNITS[int(i)] for i, v in (fixed or {}).items()}
        free = [i for i in range(4) if i not in held]
        if not free:
            raise SoilModelError("every parameter of the wedge is held: nothing to fit")
        rng = np.random.default_rng(seed)
        firsts = [np.clip(np.asarray(start, dtype=float) / _WEDGE_UNITS, lo, hi)]
        firsts += [rng.uniform(lo, hi) for _ in range(starts - 1)]

        def full(uf: np.ndarray) -> np.ndarray:
            u = np.empty(4)
            u[free] = uf
            for i, v in held.items():
                u[i] = v
            return u

        def residuals(uf: np.ndarray) -> np.ndarray:
            return (self.forces(full(uf) * _WEDGE_UNITS, x) - y).ravel()

        best = None
        for u0 in firsts:
            res = least_squares(residuals, u0[free], bounds=(lo[free], hi[free]), loss=loss, f_scale=50.0,
                                x_scale="jac")
            if best is None or res.cost < best.cost:
                best = res
        r = residuals(best.x)
        s2 = float(r @ r) / max(r.size - len(free), 1)
        se = np.zeros(4)
        try:
            se[free] = np.sqrt(np.maximum(np.diag(np.linalg.pinv(best.jac.T @ best.jac)) * s2, 0.0))
        except np.linalg.LinAlgError:
            se[free] = math.inf
        return full(best.x) * _WEDGE_UNITS, se * _WEDGE_UNITS, math.sqrt(float(r @ r) / r.size)

    def correlation(self, theta: np.ndarray, x: np.ndarray) -> np.ndarray:
        """The correlation (4, 4) of the estimates of ``c, phi, delta, gamma`` at ``theta``, from the
        Jacobian of the residuals (``(J^T J)^-1`` normalized; central differences): how far the
        record separates them. ``corr(c, phi)`` near -1 is the c-phi valley of §5.2.4.1 (a little
        cohesion explains the forces as well as a little more friction)."""
        u = np.asarray(theta, dtype=float) / _WEDGE_UNITS
        h = 1e-6
        jac = np.stack([(self.forces((u + h * e) * _WEDGE_UNITS, x)
                         - self.forces((u - h * e) * _WEDGE_UNITS, x)).ravel() / (2 * h) for e in np.eye(4)], axis=-1)
        cov = np.linalg.pinv(jac.T @ jac)
        sd = np.sqrt(np.maximum(np.diag(cov), 1e-300))
        return np.clip(cov / np.outer(sd, sd), -1.0, 1.0)

    def profile(self, x: np.ndarray, y: np.ndarray, theta: np.ndarray, values: np.ndarray, *,
                index: int = 1, fixed: dict[int, float] | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The profile of the cost along one parameter: for each of ``values`` (of parameter
        ``index`` of ``c, phi, delta, gamma``, in its units: Pa, rad, rad, N/m^3) the other three
        fitted again with bounds, by continuation outward from ``theta`` (the fit's optimum).
        ``fixed``: parameters held at these values as in :meth:`fit` (not ``index``).
        Returns the RMS residual [N] (as :meth:`fit`'s) and the parameters (len(values), 4) at each."""
        lo, hi = (np.array(b) / _WEDGE_UNITS for b in WEDGE_BOUNDS)
        held = {int(i): float(v) / _WEDGE_UNITS[int(i)] for i, v in (fixed or {}).items() if int(i) != index}
        free = [i for i in range(4) if i != index and i not in held]
        values = np.asarray(values, dtype=float)
        u_best = np.clip(np.asarray(theta, dtype=float) / _WEDGE_UNITS, lo, hi)
        rms = np.full(values.size, np.nan)
        params = np.full((values.size, 4), np.nan)
        order = np.argsort(np.abs(values - theta[index]))
        start = int(order[0])
        for direction in (1, -1):
            guess = u_best[free].copy()
            idx = range(start, values.size) if direction == 1 else range(start - 1, -1, -1)
            for i in idx:
                fixed = values[i] / _WEDGE_UNITS[index]

                def full(uf: np.ndarray, fixed: float = fixed) -> np.ndarray:
                    u = np.empty(4)
                    u[free], u[index] = uf, fixed
                    for j, v in held.items():
                        u[j] = v
                    return u

                def residuals(uf: np.ndarray) -> np.ndarray:
                    return (self.forces(full(uf) * _WEDGE_UNITS, x) - y).ravel()

                res = least_squares(residuals, np.clip(guess, lo[free], hi[free]), bounds=(lo[free], hi[free]),
                                    x_scale="jac")
                guess = res.x
                u = full(res.x)
                params[i] = u * _WEDGE_UNITS
                rms[i] = math.sqrt(2.0 * float(res.cost) / y.size)
        return rms, params


def residual_autocorrelation(res: np.ndarray, dig: np.ndarray, max_lag: int) -> np.ndarray:
    """The autocorrelation (max_lag + 1,) of residuals (n, m) at lags 0..max_lag samples, pooled over
    their m columns and over the digs, lag pairs taken within a dig only (1 at lag 0; zeros for
    residuals that are all equal)."""
    r = np.asarray(res, dtype=float)
    r = r.reshape(len(r), -1) - r.reshape(len(r), -1).mean(axis=0)
    dig = np.asarray(dig)
    num = np.zeros(max_lag + 1)
    count = np.zeros(max_lag + 1)
    for k in np.unique(dig):
        e = r[dig == k]
        for lag in range(min(max_lag, len(e) - 1) + 1):
            num[lag] += float((e[lag:] * e[:len(e) - lag]).sum())
            count[lag] += (len(e) - lag) * e.shape[1]
    if count[0] == 0 or num[0] <= 0.0:
        return np.zeros(max_lag + 1)
    cov = np.divide(num, count, out=np.zeros_like(num), where=count > 0)
    return cov / cov[0]


def residual_inflation(res: np.ndarray, dig: np.ndarray, max_lag: int) -> float:
    """How much the residuals' correlation along each dig inflates the variance of a sum of them
    (>= 1): ``1 + 2 sum_k (1 - k / (L + 1)) r_k`` over lags ``k = 1..L`` (``L = max_lag`` samples;
    the Bartlett window of Newey and West 1987, which keeps the estimate from over-counting noisy
    long lags), ``r_k`` of :func:`residual_autocorrelation`. White residuals give 1; an AR(1)
    series of coefficient ``a`` tends to ``(1 + a) / (1 - a)`` as ``L`` grows. A likelihood-ratio
    interval from correlated residuals is too narrow by its square root unless its level is scaled
    by it."""
    rho = residual_autocorrelation(res, dig, max_lag)
    lags = np.arange(1, max_lag + 1)
    return max(1.0, 1.0 + 2.0 * float(((1.0 - lags / (max_lag + 1)) * rho[1:]).sum()))


def advance_speed(x: np.ndarray, t: np.ndarray, dig: np.ndarray) -> np.ndarray:
    """The tip's horizontal advance towards the arm's base (n,) [m/s], ``max(-dx/dt, 0)`` by central
    differences within each dig (one-sided at its ends; 0 for a dig of one sample): the speed at
    which soil enters the wedge of a drag (the world's is measured along the blade's push)."""
    x, t, dig = (np.asarray(a, dtype=float) for a in (x, t, dig))
    out = np.zeros(x.size)
    for k in np.unique(dig):
        idx = np.flatnonzero(dig == k)
        if idx.size > 1:
            out[idx] = np.maximum(-np.gradient(x[idx], t[idx]), 0.0)
    return out


def touchdown_samples(z: np.ndarray, dig: np.ndarray) -> np.ndarray:
    """(n,) True for the samples at the start of each dig while the tip still rises off the
    touch-down (§7.1.3): the bucket's bottom was pressed onto the soil to find it, a bearing load no
    cutting model describes; a calibration leaves them out."""
    z = np.asarray(z, dtype=float)
    dig = np.asarray(dig)
    out = np.zeros(z.size, dtype=bool)
    for k in np.unique(dig):
        idx = np.flatnonzero(dig == k)
        rising = np.diff(z[idx]) > 0
        n = int(np.argmin(rising)) if not rising.all() else rising.size
        out[idx[:n]] = True
    return out
