"""Memory-based self-tuning of script parameters (Rowe 1997 §5, §6.2): numpy/scipy only.

* :class:`Memory` keeps every trial: the script parameters tried (the inputs x, 7 in §6.2) and the
  outcomes (time t, pile radius r, pile angle theta).
* :class:`LWR` is the locally weighted linear regression of §6.2: inputs normalized to [0, 1] by the
  memory's range (a constant input maps to 0); weights ``w_i = exp(-D(x_i - q)^2 / W)`` with ``D``
  the Euclidean distance; ``Z = diag(w) X`` and ``v = diag(w) y`` with a column of ones appended to
  X; ``Z beta = v`` solved by the singular value decomposition (singular values below ``rcond``
  times the largest are dropped); ``y_hat = beta^T [q, 1]``. One beta per output, the same weights.
  The kernel width W is chosen among 2^-1 ... 2^-8 by leave-one-out cross-validation (the sum over
  the outputs of the squared leave-one-out errors, each output scaled by its spread: assumed, the
  thesis does not say how the three outputs are combined).
* Confidence (§5.4, where the thesis names it without a formula; **assumed**): a prediction carries
  its *support*, the sum of the kernel weights at the query (how many data points' worth of
  evidence it rests on), and a standard error per output: the root mean squared leave-one-out
  residual at the chosen width, grown by the query's leverage in the weighted fit (the sandwich
  ``(Z^T Z)^+ X^T W^4 X (Z^T Z)^+``); below ``MIN_SUPPORT`` the standard error is infinite: the data
  cannot support the prediction, whose value (the fit of the nearest points, the weights rescaled by their
  common factor so that they cannot underflow) stays finite. :func:`select_action` minimizes the cost (its expectation under those
  errors when ``Objective.uncertainty``; the truck loop turns that off, configs/dump_trial.yaml's
  ``learning.expected_cost``: on a handful of trials the errors are those of an under-determined 7-input
  fit and held the learner at its best early trial), adds ``support_penalty`` per missing unit of
  support below ``min_support`` and per
  ``trust_radius`` beyond ``trust_radius`` from the nearest remembered trial, and keeps the simplex
  within ``margin`` of the data's normalized box.
* Failures (§5.4.1: a data point "stored with a very high cost"): the memory's fourth output is 1 for
  a failed trial; the model predicts it like the others and the cost adds ``failure_cost`` times the
  prediction (clipped to [0, 1]); a failed trial is never a starting point.
* :func:`select_action`: the downhill simplex (scipy's Nelder-Mead) on the cost predicted through
  the model, from 4 starts: the remembered trials with the lowest cost, lowest time, lowest radial
  error and lowest tangential error, kept distinct (the next best by the same criterion when one is
  taken); the best of the 4 results is the next action.
* :func:`placement_cost` is the cost of §6.2, ``c = w1 t + w2 ((r_d - r)^2 + r_d^2 (theta_d - theta)^2)``
  with theta in radians (the ``r_d^2`` equalizes the arc length ``s = r theta``).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.optimize import minimize

WIDTHS = tuple(2.0 ** -k for k in range(1, 9))  # 2^-1 ... 2^-8 (§6.2)
# below this kernel support (the sum of the weights: a millionth of one data point's worth of evidence at
# the query) a prediction's standard error is infinite, "unknown" (Atkeson, Moore & Schaal 1997: too few
# effective points to support a local fit; the value assumed)
MIN_SUPPORT = 1e-6


def placement_cost(t, r, theta, r_d: float, theta_d: float, w1: float, w2: float):
    """§6.2: ``w1 t + w2 ((r_d - r)^2 + r_d^2 (theta_d - theta)^2)`` (t [s], r [m], theta [rad])."""
    return w1 * np.asarray(t) + w2 * ((r_d - np.asarray(r)) ** 2 + r_d ** 2 * (theta_d - np.asarray(theta)) ** 2)


def svd_solve(z: np.ndarray, v: np.ndarray, rcond: float = 1e-8) -> np.ndarray:
    """The least-squares (minimum-norm) solution of ``Z beta = v`` by the SVD; ``v`` may be (n,) or (n, k)."""
    u, s, vt = np.linalg.svd(z, full_matrices=False)
    # drop the singular values below rcond times the largest, and any whose reciprocal would overflow (a
    # matrix of subnormal entries: 1 / s is inf and inf * 0 is NaN)
    keep = (s > rcond * (s[0] if s.size else 0.0)) & (s > 1.0 / np.finfo(float).max)
    inv = np.zeros_like(s)
    inv[keep] = 1.0 / s[keep]
    uv = u.T @ v
    return vt.T @ (inv * uv if uv.ndim == 1 else inv[:, None] * uv)


@dataclasses.dataclass(frozen=True)
class Prediction:
    """A prediction of the outcomes at one query: values (k,), standard errors (k,), support."""

    y: np.ndarray
    stderr: np.ndarray
    support: float


class LWR:
    """Locally weighted linear regression on a memory of (x, y) (see the module docstring).

    Args:
        x: (n, m) inputs. y: (n, k) outputs.
        width: the kernel width W; chosen by leave-one-out among ``widths`` when None.
        min_support: below this support at a query the prediction's standard error is infinite (unknown).
    """

    def __init__(self, x: np.ndarray, y: np.ndarray, *, width: float | None = None,
                 widths: tuple[float, ...] = WIDTHS, rcond: float = 1e-8, width_outputs: int | None = None,
                 min_support: float = MIN_SUPPORT):
        self.min_support = min_support
        self.x = np.atleast_2d(np.asarray(x, dtype=float))
        y = np.asarray(y, dtype=float)
        self.y = y.reshape(len(y), -1)
        self.rcond = rcond
        self.lo = self.x.min(axis=0)
        span = self.x.max(axis=0) - self.lo
        self.span = np.where(span > 0, span, 1.0)
        self.xn = self.normalize(self.x)
        self.width_outputs = self.y.shape[1] if width_outputs is None else width_outputs
        self.loo_errors = {w: self.loo_error(w) for w in widths} if width is None else {}
        self.width = width if width is not None else min(self.loo_errors, key=self.loo_errors.get)
        # the prediction error of each output: the mean squared leave-one-out residual at the chosen width
        self.loo_mse = np.mean(self.loo_residuals(self.width) ** 2, axis=0) if len(self.x) > 1 \
            else np.full(self.y.shape[1], np.inf)

    def normalize(self, x: np.ndarray) -> np.ndarray:
        """Inputs mapped to [0, 1] by the memory's range."""
        return (np.asarray(x, dtype=float) - self.lo) / self.span

    def weights(self, qn: np.ndarray, width: float, xn: np.ndarray | None = None) -> np.ndarray:
        """``exp(-D^2 / W)`` of each (normalized) data point from the normalized query ``qn``."""
        xn = self.xn if xn is None else xn
        return np.exp(-np.sum((xn - qn) ** 2, axis=1) / width)

    def _fit(self, qn: np.ndarray, width: float, idx: np.ndarray | None = None):
        """The weighted fit at ``qn``: beta, the kernel weights ``w`` (for the support), and ``Z``, ``v``
        built from the weights rescaled so that the largest is of order 1.

        Weighted least squares is unchanged by a common factor of the weights, but the absolute weights
        of a query far from every point (``D^2 / W`` beyond ~700) underflow to subnormals or zero: the SVD
        then sees a matrix of subnormals, ``1 / s`` overflows and the fit is NaN (or all weights are 0 and
        the fit is silently 0). The common factor is taken out (Atkeson, Moore & Schaal 1997 on the
        conditioning of the weighted fit): by an exact power of two while the largest weight is a normal
        number (an exact scaling: in the runs measured the fit was bit for bit that of the absolute
        weights), else in the log domain."""
        xn, y = (self.xn, self.y) if idx is None else (self.xn[idx], self.y[idx])
        w = self.weights(qn, width, xn)
        wmax = float(w.max()) if w.size else 0.0
        if wmax >= np.finfo(float).tiny:
            wf = np.ldexp(w, -np.frexp(wmax)[1])
        elif w.size:
            d2 = np.sum((xn - qn) ** 2, axis=1)
            wf = np.exp(-(d2 - d2.min()) / width)
        else:
            wf = w
        xa = np.hstack([xn, np.ones((len(xn), 1))])
        z, v = wf[:, None] * xa, wf[:, None] * y
        return svd_solve(z, v, self.rcond), w, z, v

    def predict_normalized(self, qn: np.ndarray, width: float | None = None) -> Prediction:
        """The prediction at a normalized query, with its standard error and support (see the module docstring)."""
        width = self.width if width is None else width
        beta, w, z, v = self._fit(qn, width)
        qa = np.append(qn, 1.0)
        yhat = qa @ beta
        support = float(w.sum())
        if not support >= self.min_support:  # too little data near the query: the error is unknown
            return Prediction(yhat, np.full(self.y.shape[1], np.inf), support)
        # var(beta) of the weighted fit (sandwich): (Z^T Z)^+ X^T W^4 X (Z^T Z)^+ per unit noise variance;
        # with the rescaled weights of Z (the sandwich is unchanged by a common factor of the weights)
        xa = np.hstack([self.xn, np.ones((len(self.xn), 1))])
        wf = z[:, -1]
        zz = np.linalg.pinv(z.T @ z, rcond=self.rcond)
        meat = (xa * (wf ** 4)[:, None]).T @ xa
        leverage = max(float(qa @ zz @ meat @ zz @ qa), 0.0)
        return Prediction(yhat, np.sqrt(self.loo_mse * (1.0 + leverage)), support)

    def predict(self, q: np.ndarray) -> Prediction:
        """The prediction at a query in the original units."""
        return self.predict_normalized(self.normalize(q))

    def loo_residuals(self, width: float) -> np.ndarray:
        """(n, k) leave-one-out residuals at ``width``: each point predicted from all the others."""
        n = len(self.x)
        res = np.zeros_like(self.y)
        for i in range(n):
            idx = np.r_[0:i, i + 1:n]
            beta, *_ = self._fit(self.xn[i], width, idx)
            res[i] = np.append(self.xn[i], 1.0) @ beta - self.y[i]
        return res

    def loo_error(self, width: float) -> float:
        """Leave-one-out squared error at ``width``, summed over the first ``width_outputs`` outputs scaled
        by their spread."""
        k = self.width_outputs
        scale = self.y[:, :k].std(axis=0)
        scale = np.where(scale > 0, scale, 1.0)
        return float(np.sum((self.loo_residuals(width)[:, :k] / scale) ** 2))


class Memory:
    """The trials so far: inputs (n, m) and outcomes (n, 4) = time [s], r [m], theta [rad], failed [0/1]
    (a trial that did not do its task, e.g. left soil in the bucket: §5.4.1's data point "stored with a
    very high cost")."""

    def __init__(self, m: int):
        self.x = np.zeros((0, m))
        self.y = np.zeros((0, 4))

    def add(self, x: np.ndarray, t: float, r: float, theta: float, failed: float = 0.0) -> None:
        self.x = np.vstack([self.x, np.asarray(x, dtype=float)])
        self.y = np.vstack([self.y, [t, r, theta, failed]])

    def __len__(self) -> int:
        return len(self.x)


@dataclasses.dataclass(frozen=True)
class Objective:
    """What to minimize: the cost of §6.2 about the target (r_d [m], theta_d [rad]) with weights w1, w2,
    plus ``failure_cost`` for a failed trial (§5.4.1), and how far to trust the model (see the module
    docstring)."""

    r_d: float
    theta_d: float
    w1: float
    w2: float
    min_support: float = 0.5
    support_penalty: float = 200.0
    margin: float = 0.1
    failure_cost: float = 500.0
    trust_radius: float = 0.0
    uncertainty: bool = True

    def cost(self, t, r, theta, failed=0.0):
        return placement_cost(t, r, theta, self.r_d, self.theta_d, self.w1, self.w2) \
            + self.failure_cost * np.asarray(failed, dtype=float)

    def expected_cost(self, p: Prediction) -> float:
        """The cost's expectation under the prediction's errors (each output's standard error, taken as
        independent): the quadratic placement terms gain ``w2 (se_r^2 + r_d^2 se_theta^2)``, so that an
        uncertain prediction of a perfect placement is not worth a certain one (§5.3.3's reliability;
        assumed form). The predicted failure is clipped to [0, 1]."""
        t, r, th, *rest = p.y
        failed = float(np.clip(rest[0], 0.0, 1.0)) if rest else 0.0
        c = float(self.cost(t, r, th, failed))
        if self.uncertainty:
            se = np.where(np.isfinite(p.stderr), p.stderr, 0.0)
            c += self.w2 * (se[1] ** 2 + self.r_d ** 2 * se[2] ** 2)
        return c


def trial_costs(memory: Memory, obj: Objective) -> np.ndarray:
    """The measured cost of each remembered trial (failures included)."""
    y = memory.y
    return obj.cost(y[:, 0], y[:, 1], y[:, 2], y[:, 3] if y.shape[1] > 3 else 0.0)


def starting_points(memory: Memory, obj: Objective, k: int = 4) -> list[int]:
    """Indices of the remembered trials with the lowest cost, time, radial error and tangential error,
    kept distinct (§6.2); a failed trial is never a start."""
    t, r, th = memory.y[:, :3].T
    failed = memory.y[:, 3] > 0.5 if memory.y.shape[1] > 3 else np.zeros(len(t), bool)
    keys = (trial_costs(memory, obj), t, np.abs(obj.r_d - r), obj.r_d * np.abs(obj.theta_d - th))
    chosen: list[int] = []
    ok = ~failed if not failed.all() else np.ones(len(t), bool)
    for key in keys[:k]:
        for i in np.argsort(key, kind="stable"):
            if not ok[i]:
                continue
            if int(i) not in chosen and not any(np.allclose(memory.x[i], memory.x[j]) for j in chosen):
                chosen.append(int(i))
                break
    return chosen


@dataclasses.dataclass(frozen=True)
class Selection:
    """The action chosen: x (m,), its predicted cost, the prediction, the kernel width, the starts."""

    x: np.ndarray
    predicted_cost: float
    prediction: Prediction
    width: float
    starts: list[int]


def select_action(memory: Memory, obj: Objective, *, lower: np.ndarray | None = None,
                  upper: np.ndarray | None = None, maxiter: int = 600) -> Selection:
    """The next action: Nelder-Mead on the predicted cost from the 4 starting points (§6.2).

    ``lower``/``upper`` (original units) bound the search besides the data's box plus ``margin``.
    The cost minimized is the expected cost under the prediction's errors (:meth:`Objective.expected_cost`)
    plus the penalties that keep the search where the model has data (§5.4.1: the action that best
    minimizes the cost "within some acceptable bounds on the confidence of the prediction"):
    ``support_penalty`` per unit of kernel support below ``min_support``, and, when ``trust_radius`` > 0,
    ``support_penalty`` per ``trust_radius`` that the query lies beyond ``trust_radius`` from the nearest
    remembered trial (normalized units)."""
    model = LWR(memory.x, memory.y, width_outputs=3)
    lo_n = np.full(memory.x.shape[1], -obj.margin)
    hi_n = np.full(memory.x.shape[1], 1.0 + obj.margin)
    if lower is not None:
        lo_n = np.maximum(lo_n, model.normalize(lower))
    if upper is not None:
        hi_n = np.minimum(hi_n, model.normalize(upper))
    const = model.x.max(axis=0) == model.x.min(axis=0)
    lo_n[const], hi_n[const] = 0.0, 0.0

    def penalty(qn: np.ndarray, p: Prediction) -> float:
        pen = obj.support_penalty * max(obj.min_support - p.support, 0.0)
        if obj.trust_radius > 0:
            d_nn = float(np.sqrt(np.min(np.sum((model.xn - qn) ** 2, axis=1))))
            pen += obj.support_penalty * max(d_nn / obj.trust_radius - 1.0, 0.0)
        return pen

    def predicted(qn: np.ndarray) -> float:
        qn = np.clip(qn, lo_n, hi_n)
        p = model.predict_normalized(qn)
        return obj.expected_cost(p) + penalty(qn, p)

    starts = starting_points(memory, obj)
    best = None
    for i in starts:
        x0 = np.clip(model.xn[i], lo_n, hi_n)
        res = minimize(predicted, x0, method="Nelder-Mead", bounds=list(zip(lo_n, hi_n)),
                       options={"maxiter": maxiter, "xatol": 1e-4, "fatol": 1e-6})
        if best is None or res.fun < best.fun:
            best = res
    qn = np.clip(best.x, lo_n, hi_n)
    x = model.lo + qn * model.span
    return Selection(x, float(best.fun), model.predict_normalized(qn), model.width, starts)
