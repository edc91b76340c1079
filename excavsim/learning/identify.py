"""Identifying DiMaio's bucket-ground model from force records (DiMaio 1998 §5.5.1).

With soil shearing neglected (eq. 5.57) the model's tangential and normal forces are

    f_t = -b_t0 s_p v_t - mu |f_n| v_t/|v_t| + epsilon cos(alpha) V - rho sin(alpha) g V + f_kt
    f_n = -b_n0 s_p v_n + (epsilon, -rho g V) . n + f_kn

with the stiffness force ``f_k = -k T s / (T s + 1) x`` of the lagging centre (eqs. 5.44, 5.46,
5.59-5.61). The lag is what is not linear in the parameters. In the discrete form the world uses
(backward Euler, ``a = T / (T + T_s)``; :mod:`excavsim.world.dimaio`) the stiffness force obeys
``f_k,i[k] = a_i (f_k[k-1] . e_i[k] - k dp[k] . e_i[k])`` along each axis ``e_i`` of the bucket
frame, and ``f_k[k-1]`` is the measured total force of the previous sample less the other
components. Substituting it gives, per axis, an equation **linear** in the augmented parameters
``(theta, a_i, a_i theta, a_i k)`` with ``theta = (b_t0, b_n0, mu, epsilon, rho)`` (the thesis:
"linear in parameters and therefore amenable to ... least squares or recursive least squares"):

    f_i[k] = sum_j theta_j w_j[k].e_i[k] + a_i F[k-1].e_i[k] - sum_j (a_i theta_j) w_j[k-1].e_i[k]
             - (a_i k) dp[k].e_i[k]

where ``w_j`` is the world-plane force of a unit ``theta_j`` (the Coulomb regressor reads the
measured normal force). :func:`batch_least_squares` solves it at once, :func:`recursive_least_squares`
sample by sample with a forgetting factor (Fig. 5.40); both recover ``k = (a_t k + a_n k) / (a_t +
a_n)`` and ``T_i = a_i T_s / (1 - a_i)``. Without noise the recovery is exact to round-off. With
noise the previous force is a noisy regressor (an errors-in-variables bias); :func:`output_error_fit`
then minimizes eq. 5.55, the output error of the simulated model (:func:`simulate`, this module's
own implementation of the equations) over the parameters, from the least-squares estimate.

numpy and scipy only: the records are arrays (:class:`PlanarRecord`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy.optimize import least_squares

G_M_S2 = 9.81
NAMES = ("b_t0", "b_n0", "mu", "eps", "rho", "k", "T_rt", "T_rn")
UNITS = {"b_t0": "N s/m^2", "b_n0": "N s/m^2", "mu": "-", "eps": "N/m^3", "rho": "kg/m^3", "k": "N/m", "T_rt": "s",
         "T_rn": "s"}
_THETA = NAMES[:5]
_SCALE = np.array([1e4, 1e4, 1.0, 1e4, 1e3])  # of theta, so that the unknowns are of order one
_K_SCALE = 1e5


@dataclasses.dataclass
class PlanarRecord:
    """A force record in the arm plane, with the model's states (eq. 5.54's X(t) and S(t)).

    Attributes:
        r, z: (n,) the cutting edge [m] (r radial, z up).
        t, n: (n, 2) the cutting surface's unit tangent and normal in (r, z).
        sp: (n,) penetration [m] (0: out of the soil).
        load: (n,) the load in the bucket [m^3].
        force_tn: (n, 2) the measured force on the bucket along t and n [N].
        dt: the sample period [s].
        segment: (n,) which contiguous run (dig) each sample belongs to; the model restarts at each.
    """

    r: np.ndarray
    z: np.ndarray
    t: np.ndarray
    n: np.ndarray
    sp: np.ndarray
    load: np.ndarray
    force_tn: np.ndarray
    dt: float
    segment: np.ndarray | None = None

    def __post_init__(self):
        self.r, self.z, self.sp, self.load = (np.asarray(a, dtype=float) for a in (self.r, self.z, self.sp, self.load))
        self.t, self.n, self.force_tn = (np.asarray(a, dtype=float).reshape(-1, 2) for a in
                                         (self.t, self.n, self.force_tn))
        if self.segment is None:
            self.segment = np.zeros(self.r.size)
        self.segment = np.asarray(self.segment, dtype=float)

    def __len__(self) -> int:
        return int(self.r.size)

    @property
    def force_rz(self) -> np.ndarray:
        """(n, 2) the measured force in (r, z) [N]."""
        return self.force_tn[:, :1] * self.t + self.force_tn[:, 1:] * self.n

    def first(self) -> np.ndarray:
        """(n,) True where a run starts (no previous sample)."""
        f = np.ones(len(self), dtype=bool)
        f[1:] = self.segment[1:] != self.segment[:-1]
        return f


def _regressors(rec: PlanarRecord, v_eps: float, g: float, normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World-plane forces of a unit of each theta, (n, 5, 2), and the edge's moves dp (n, 2)."""
    first = rec.first()
    dp = np.zeros((len(rec), 2))
    dp[1:, 0] = np.diff(rec.r)
    dp[1:, 1] = np.diff(rec.z)
    dp[first] = 0.0
    v = dp / rec.dt
    vt = (v * rec.t).sum(1)
    vn = (v * rec.n).sum(1)
    ins = (rec.sp > 0)[:, None]
    w = np.zeros((len(rec), 5, 2))
    w[:, 0] = np.where(ins, -(rec.sp * vt)[:, None] * rec.t, 0.0)
    w[:, 1] = np.where(ins, -(rec.sp * vn)[:, None] * rec.n, 0.0)
    w[:, 2] = np.where(ins, -(np.abs(normal) * vt / np.maximum(np.abs(vt), v_eps))[:, None] * rec.t, 0.0)
    w[:, 3, 0] = np.where(rec.sp > 0, rec.load, 0.0)
    w[:, 4, 1] = -g * rec.load
    return w, dp


def regression(rec: PlanarRecord, *, v_eps: float = 0.02, g: float = G_M_S2) -> tuple[np.ndarray, np.ndarray]:
    """The linear regression of the augmented parameters: rows (2n, 19) and targets (2n,).

    Row ``2k`` is the tangential equation of sample ``k``, row ``2k + 1`` the normal one. The
    unknowns are, scaled to order one: theta / _SCALE (5), a_t, a_n, a_t theta / _SCALE (5),
    a_n theta / _SCALE (5), a_t k / _K_SCALE, a_n k / _K_SCALE.
    """
    n = len(rec)
    w, dp = _regressors(rec, v_eps, g, rec.force_tn[:, 1])
    f = rec.force_rz
    first = rec.first()
    prev_f = np.zeros_like(f)
    prev_w = np.zeros_like(w)
    prev_f[1:], prev_w[1:] = f[:-1], w[:-1]
    prev_f[first], prev_w[first] = 0.0, 0.0
    ins = rec.sp > 0
    rows = np.zeros((n, 2, 19))
    for i, e in enumerate((rec.t, rec.n)):
        rows[:, i, 0:5] = np.einsum("njc,nc->nj", w, e) * _SCALE
        rows[:, i, 5 + i] = np.where(ins, (prev_f * e).sum(1), 0.0)
        lo = 7 + 5 * i
        rows[:, i, lo:lo + 5] = np.where(ins[:, None], -np.einsum("njc,nc->nj", prev_w, e) * _SCALE, 0.0)
        rows[:, i, 17 + i] = np.where(ins, -(dp * e).sum(1) * _K_SCALE, 0.0)
    return rows.reshape(2 * n, 19), rec.force_tn.reshape(2 * n)


def _physical(psi: np.ndarray, dt: float) -> dict[str, float]:
    theta = psi[:5] * _SCALE
    a_t, a_n = psi[5], psi[6]
    k = (psi[17] + psi[18]) * _K_SCALE / (a_t + a_n)
    out = dict(zip(_THETA, (float(x) for x in theta)))
    out.update(k=float(k), T_rt=float(a_t * dt / (1 - a_t)), T_rn=float(a_n * dt / (1 - a_n)))
    return out


def batch_least_squares(rec: PlanarRecord, *, v_eps: float = 0.02, g: float = G_M_S2) -> dict[str, float]:
    """The model's parameters (:data:`NAMES`) from a record by linear least squares (Table 5.3)."""
    a, y = regression(rec, v_eps=v_eps, g=g)
    norms = np.linalg.norm(a, axis=0)
    keep = norms > 1e-12 * norms.max()
    psi = np.zeros(a.shape[1])
    psi[keep] = np.linalg.lstsq(a[:, keep] / norms[keep], y, rcond=None)[0] / norms[keep]
    return _physical(psi, rec.dt)


def recursive_least_squares(rec: PlanarRecord, *, forgetting: float = 0.999, p0: float = 1e9, v_eps: float = 0.02,
                            g: float = G_M_S2) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Recursive least squares with exponential forgetting over the samples of a record (Fig. 5.40).

    Each sample's two equations update the estimate: ``K = P H^T (lambda I + H P H^T)^-1``,
    ``psi += K (y - H psi)``, ``P = (P - K H P) / lambda``, from ``psi = 0``, ``P = p0 I``.

    Returns:
        the physical parameters after every sample, ``name -> (n,)`` (NaN while undetermined), and
        the final augmented estimate.
    """
    a, y = regression(rec, v_eps=v_eps, g=g)
    m = a.shape[1]
    psi = np.zeros(m)
    p = np.eye(m) * p0
    hist = {k: np.full(len(rec), np.nan) for k in NAMES}
    lam = float(forgetting)
    for k in range(len(rec)):
        h = a[2 * k:2 * k + 2]
        yy = y[2 * k:2 * k + 2]
        ph = p @ h.T
        gain = ph @ np.linalg.inv(lam * np.eye(2) + h @ ph)
        psi = psi + gain @ (yy - h @ psi)
        p = (p - gain @ h @ p) / lam
        p = 0.5 * (p + p.T)
        with np.errstate(divide="ignore", invalid="ignore"):
            for name, value in _physical(psi, rec.dt).items():
                hist[name][k] = value
    return hist, psi


def simulate(params: dict[str, float], rec: PlanarRecord, *, v_eps: float = 0.02, g: float = G_M_S2,
             substeps: int = 1, shear: tuple[float, float] | None = None) -> np.ndarray:
    """The model's force along t and n (n, 2) [N] on the record's path (eqs. 5.41-5.49).

    This module's own implementation of the equations in the discrete form of the world's
    (backward-Euler lag, velocities as backward differences, the Coulomb direction regularized
    below ``v_eps``); the model restarts at each run of the record.

    Args:
        substeps: steps of the model per record sample: the path, the surface's axes, the
            penetration and the load interpolated linearly in between (a record at the F/T rate of a
            model stepped at the controller's; 1: at the samples themselves).
        shear: ``(width [m], s_bucket [m])``: with a shear strength ``S`` in ``params`` (Pa), eq. 5.45's
            failure: where ``|f_kn| >= S w d_p`` (``d_p = s_p / |n_z|``, at most ``s_bucket``) the
            stiffness is relieved; None (or no ``S``): shearing neglected (eq. 5.57).
    """
    b_t0, b_n0, mu, eps, rho, k = (float(params[x]) for x in ("b_t0", "b_n0", "mu", "eps", "rho", "k"))
    dt = rec.dt / max(int(substeps), 1)
    ns = max(int(substeps), 1)
    a_t = params["T_rt"] / (params["T_rt"] + dt)
    a_n = params["T_rn"] / (params["T_rn"] + dt)
    strength = float(params.get("S", math.inf)) if shear is not None else math.inf
    width, s_b = shear if shear is not None else (0.0, math.inf)
    first = rec.first()
    out = np.zeros((len(rec), 2))
    r, z, sp_all, load = rec.r.tolist(), rec.z.tolist(), rec.sp.tolist(), rec.load.tolist()
    tt, nn = rec.t.tolist(), rec.n.tolist()
    er = ez = 0.0
    pr = pz = 0.0
    for i in range(len(rec)):
        if first[i]:
            er = ez = 0.0
            pr, pz = r[i], z[i]
        f_t = f_n = 0.0
        for j in range(1 if first[i] else ns):
            u = 1.0 if first[i] else (j + 1) / ns
            w0 = 1.0 - u
            cr = r[i] if first[i] else w0 * r[i - 1] + u * r[i]
            cz = z[i] if first[i] else w0 * z[i - 1] + u * z[i]
            if first[i]:
                t0, t1, n0, n1, sp, vol = tt[i][0], tt[i][1], nn[i][0], nn[i][1], sp_all[i], load[i]
            else:
                t0 = w0 * tt[i - 1][0] + u * tt[i][0]
                t1 = w0 * tt[i - 1][1] + u * tt[i][1]
                tn = math.hypot(t0, t1)
                t0, t1 = t0 / tn, t1 / tn
                n0 = w0 * nn[i - 1][0] + u * nn[i][0]
                n1 = w0 * nn[i - 1][1] + u * nn[i][1]
                nl = math.hypot(n0, n1)
                n0, n1 = n0 / nl, n1 / nl
                sp = w0 * sp_all[i - 1] + u * sp_all[i]
                vol = w0 * load[i - 1] + u * load[i]
            dr, dz = cr - pr, cz - pz
            pr, pz = cr, cz
            flr = eps * vol if sp > 0 else 0.0
            flz = -rho * g * vol
            flt = flr * t0 + flz * t1
            fln = flr * n0 + flz * n1
            if sp <= 0:
                er = ez = 0.0
                f_t, f_n = flt, fln
                continue
            er -= dr
            ez -= dz
            et = a_t * (er * t0 + ez * t1)
            en = a_n * (er * n0 + ez * n1)
            er, ez = et * t0 + en * n0, et * t1 + en * n1
            fkt, fkn = k * et, k * en
            if strength < math.inf:
                dp = min(sp / max(abs(n1), 1e-6), s_b)
                if abs(fkn) >= strength * width * dp:  # eq. 5.45: shear failure relieves the stiffness
                    er = ez = 0.0
                    fkt = fkn = 0.0
            vt = (dr * t0 + dz * t1) / dt
            vn = (dr * n0 + dz * n1) / dt
            f_n = -sp * b_n0 * vn + fkn + fln
            f_t = -sp * b_t0 * vt + fkt + flt - mu * abs(f_n) * vt / max(abs(vt), v_eps)
        out[i] = f_t, f_n
    return out


def output_error_fit(rec: PlanarRecord, start: dict[str, float], *, v_eps: float = 0.02, g: float = G_M_S2,
                     bounds: dict[str, tuple[float, float]] | None = None, fixed: dict[str, float] | None = None,
                     substeps: int = 1, shear: tuple[float, float] | None = None, weights: np.ndarray | None = None,
                     ) -> tuple[dict[str, float], dict[str, float], float]:
    """Minimize eq. 5.55, the output error of :func:`simulate`, over the parameters from ``start``.

    Args:
        bounds: per parameter (low, high); default non-negative, time constants 1e-3 to 1e3 s, the
            shear strength ``LAG_BOUNDS["S"]``.
        fixed: parameters held at the given values.
        substeps, shear: as :func:`simulate`; with ``shear`` and an ``S`` in ``start`` the shear
            strength is fitted too.
        weights: (n,) per-sample weights of the residuals (default 1; 0 leaves a sample out).

    Returns:
        the parameters, their standard errors (from the Jacobian at the optimum and the residual
        variance; 0 for fixed ones) and the RMS residual [N].
    """
    fixed = dict(fixed or {})
    names = NAMES + ("S",) if (shear is not None and "S" in start) else NAMES
    free = [x for x in names if x not in fixed]
    bnd = {x: (0.0, np.inf) for x in names}
    bnd["T_rt"] = bnd["T_rn"] = (1e-3, 1e3)
    bnd["S"] = LAG_BOUNDS["S"]
    bnd.update(bounds or {})
    scale = np.array([max(abs(start[x]), 1e-3) for x in free])
    lo = np.array([bnd[x][0] for x in free]) / scale
    hi = np.array([bnd[x][1] for x in free]) / scale
    u0 = np.clip(np.array([start[x] for x in free]) / scale, lo + 1e-12, hi - 1e-12)
    y = rec.force_tn
    wts = np.ones(len(rec)) if weights is None else np.asarray(weights, dtype=float)

    def params_of(u):
        p = dict(fixed)
        p.update({x: float(v) for x, v in zip(free, u * scale)})
        return p

    def resid(u):
        return ((simulate(params_of(u), rec, v_eps=v_eps, g=g, substeps=substeps, shear=shear) - y)
                * wts[:, None]).ravel()

    res = least_squares(resid, u0, bounds=(lo, hi), x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-12)
    p = params_of(res.x)
    dof = max(res.fun.size - len(free), 1)
    s2 = float(res.fun @ res.fun) / dof
    # a parameter the residuals do not move at the optimum (its Jacobian column zero: a shear
    # strength between two shear events, say) is undetermined there: its error is inf, the rest's
    # come from the others' columns
    jac = np.asarray(res.jac)
    live = np.linalg.norm(jac, axis=0) > 1e-9 * max(float(np.linalg.norm(jac)), 1e-300)
    se = np.full(len(free), math.inf)
    try:
        cov = np.linalg.inv(jac[:, live].T @ jac[:, live]) * s2
        se[live] = np.sqrt(np.maximum(np.diag(cov), 0.0)) * scale[live]
    except np.linalg.LinAlgError:
        pass
    errors = {x: 0.0 for x in names}
    errors.update(dict(zip(free, (float(s) for s in se))))
    return p, errors, math.sqrt(float(res.fun @ res.fun) / res.fun.size)


_LAG = ("k", "T_rt", "T_rn", "S")  # what the stiffness force's path depends on
# the range of each searched (and output-error fitted) parameter [N/m, s, s, Pa]; S at its top never shears
LAG_BOUNDS = {"k": (1e2, 1e7), "T_rt": (1e-3, 1e3), "T_rn": (1e-3, 1e3), "S": (1e2, 1e9)}


def _linear_part(rec: PlanarRecord, fk: np.ndarray, *, v_eps: float, g: float,
                 weights: np.ndarray) -> tuple[np.ndarray, float]:
    """Given the stiffness forces ``fk`` (n, 2) at the samples, the non-negative least-squares
    ``(b_t0, b_n0, mu, eps, rho)`` and the weighted sum of squares left."""
    from scipy.optimize import nnls

    first = rec.first()
    dp = np.zeros((len(rec), 2))
    dp[1:, 0], dp[1:, 1] = np.diff(rec.r), np.diff(rec.z)
    dp[first] = 0.0
    v = dp / rec.dt
    vt, vn = (v * rec.t).sum(1), (v * rec.n).sum(1)
    ins = rec.sp > 0
    vol = rec.load
    a = np.zeros((len(rec), 2, 5))
    a[:, 0, 0] = np.where(ins, -rec.sp * vt, 0.0)
    a[:, 1, 1] = np.where(ins, -rec.sp * vn, 0.0)
    a[:, 0, 2] = np.where(ins, -np.abs(rec.force_tn[:, 1]) * vt / np.maximum(np.abs(vt), v_eps), 0.0)
    a[:, 0, 3] = np.where(ins, vol * rec.t[:, 0], 0.0)
    a[:, 1, 3] = np.where(ins, vol * rec.n[:, 0], 0.0)
    a[:, 0, 4] = -g * vol * rec.t[:, 1]
    a[:, 1, 4] = -g * vol * rec.n[:, 1]
    y = (rec.force_tn - fk) * weights[:, None]
    a = a * weights[:, None, None]
    scale = np.maximum(np.linalg.norm(a.reshape(-1, 5), axis=0), 1e-12)
    theta, rnorm = nnls(a.reshape(-1, 5) / scale, y.ravel())
    return theta / scale, float(rnorm) ** 2


def projected_fit(rec: PlanarRecord, start: dict[str, float], *, v_eps: float = 0.02, g: float = G_M_S2,
                  substeps: int = 1, shear: tuple[float, float] | None = None, weights: np.ndarray | None = None,
                  factors: tuple[float, ...] = (1.0,)) -> dict[str, float]:
    """A start for :func:`output_error_fit` that does not need one: the stiffness force's path
    depends only on ``k, T_rt, T_rn`` and ``S`` (the shear test of eq. 5.45 reads the stiffness
    force alone), and given it the model is linear in ``(b_t0, b_n0, mu, eps, rho)`` (eq. 5.57's
    observation, with the Coulomb term reading the measured normal force as :func:`regression`
    does). So the four are searched (Nelder-Mead in their logarithms, from ``start`` scaled by each
    of ``factors``) with the five solved by non-negative least squares at every step (variable
    projection).

    Returns:
        every parameter of ``start`` (``S`` only with ``shear``).
    """
    from scipy.optimize import minimize

    wts = np.ones(len(rec)) if weights is None else np.asarray(weights, dtype=float)
    lag = [x for x in _LAG if x in start and (x != "S" or shear is not None)]
    zero = {x: 0.0 for x in _THETA}

    def fk_of(u):
        p = dict(zero, **{x: float(math.exp(v)) for x, v in zip(lag, u)})
        p.setdefault("S", math.inf)
        return simulate(p, rec, v_eps=v_eps, g=g, substeps=substeps, shear=shear)

    def cost(u):
        return _linear_part(rec, fk_of(u), v_eps=v_eps, g=g, weights=wts)[1]

    lo = np.log([LAG_BOUNDS[x][0] for x in lag])
    hi = np.log([LAG_BOUNDS[x][1] for x in lag])
    u0 = np.log([max(float(start[x]), 1e-6) for x in lag])
    best = None
    for f in factors:
        res = minimize(cost, np.clip(u0 + math.log(f), lo, hi), method="Nelder-Mead", bounds=list(zip(lo, hi)),
                       options={"xatol": 1e-3, "fatol": 1e-6, "maxiter": 400})
        if best is None or res.fun < best.fun:
            best = res
    theta, _ = _linear_part(rec, fk_of(best.x), v_eps=v_eps, g=g, weights=wts)
    out = dict(zip(_THETA, (float(t) for t in theta)))
    out.update({x: float(math.exp(v)) for x, v in zip(lag, best.x)})
    return out
