"""Memory-based self-tuning of script parameters (001_0de172b0d6b3614b.txt §5, §6.2): numpy/scipy only.

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
  evidence it rests on), and a standard error from the weighted residuals and the query's
  leverage. :func:`select_action` does not trust a prediction with support below ``min_support``:
  it adds ``support_penalty`` per missing unit to the predicted cost, and it keeps the simplex within
  ``margin`` of the data's normalized box.
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


def placement_cost(t, r, theta, r_d: float, theta_d: float, w1: float, w2: float):
    """§6.2: ``w1 t + w2 ((r_d - r)^2 + r_d^2 (theta_d - theta)^2)`` (t [s], r [m], theta [rad])."""
    return w1 * np.asarray(t) + w2 * ((r_d - np.asarray(r)) ** 2 + r_d ** 2 * (theta_d - np.asarray(theta)) ** 2)


def svd_solve(z: np.ndarray, v: np.ndarray, rcond: float = 1e-8) -> np.ndarray:
    """The least-squares (minimum-norm) solution of ``Z beta = v`` by the SVD; ``v`` may be (n,) or (n, k)."""
    u, s, vt = np.linalg.svd(z, full_matrices=False)
    keep = s > rcond * (s[0] if s.size else 0.0)
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
    """

    def __init__(self, x: np.ndarray, y: np.ndarray, *, width: float | None = None,
                 widths: tuple[float, ...] = WIDTHS, rcond: float = 1e-8):
        self.x = np.atleast_2d(np.asarray(x, dtype=float))
        y = np.asarray(y, dtype=float)
        self.y = y.reshape(len(y), -1)
        self.rcond = rcond
        self.lo = self.x.min(axis=0)
        span = self.x.max(axis=0) - self.lo
        self.span = np.where(span > 0, span, 1.0)
        self.xn = self.normalize(self.x)
        self.loo_errors = {w: self.loo_error(w) for w in widths} if width is None else {}
        self.width = width if width is not None else min(self.loo_errors, key=self.loo_errors.get)

    def normalize(self, x: np.ndarray) -> np.ndarray:
        """Inputs mapped to [0, 1] by the memory's range."""
        return (np.asarray(x, dtype=float) - self.lo) / self.span

    def weights(self, qn: np.ndarray, width: float, xn: np.ndarray | None = None) -> np.ndarray:
        """``exp(-D^2 / W)`` of each (normalized) data point from the normalized query ``qn``."""
        xn = self.xn if xn is None else xn
        return np.exp(-np.sum((xn - qn) ** 2, axis=1) / width)

    def _fit(self, qn: np.ndarray, width: float, idx: np.ndarray | None = None):
        xn, y = (self.xn, self.y) if idx is None else (self.xn[idx], self.y[idx])
        w = self.weights(qn, width, xn)
        xa = np.hstack([xn, np.ones((len(xn), 1))])
        z, v = w[:, None] * xa, w[:, None] * y
        return svd_solve(z, v, self.rcond), w, z, v

    def predict_normalized(self, qn: np.ndarray, width: float | None = None) -> Prediction:
        """The prediction at a normalized query."""
        width = self.width if width is None else width
        beta, w, z, v = self._fit(qn, width)
        qa = np.append(qn, 1.0)
        yhat = qa @ beta
        res = v - z @ beta
        s2 = np.sum(res ** 2, axis=0) / max(float(np.sum(w ** 2)), 1e-300)  # weighted mean squared residual
        u, s, vt = np.linalg.svd(z, full_matrices=False)
        keep = s > self.rcond * (s[0] if s.size else 0.0)
        proj = (vt[keep] @ qa) / s[keep]
        leverage = float(proj @ proj)  # qa^T (Z^T Z)^+ qa
        return Prediction(yhat, np.sqrt(s2 * (1.0 + leverage)), float(w.sum()))

    def predict(self, q: np.ndarray) -> Prediction:
        """The prediction at a query in the original units."""
        return self.predict_normalized(self.normalize(q))

    def loo_error(self, width: float) -> float:
        """Leave-one-out squared error at ``width``, summed over the outputs scaled by their spread."""
        n = len(self.x)
        scale = self.y.std(axis=0)
        scale = np.where(scale > 0, scale, 1.0)
        err = 0.0
        for i in range(n):
            idx = np.r_[0:i, i + 1:n]
            beta, *_ = self._fit(self.xn[i], width, idx)
            err += float(np.sum(((np.append(self.xn[i], 1.0) @ beta - self.y[i]) / scale) ** 2))
        return err


class Memory:
    """The trials so far: inputs (n, m) and outcomes (n, 3) = time [s], r [m], theta [rad]."""

    def __init__(self, m: int):
        self.x = np.zeros((0, m))
        self.y = np.zeros((0, 3))

    def add(self, x: np.ndarray, t: float, r: float, theta: float) -> None:
        self.x = np.vstack([self.x, np.asarray(x, dtype=float)])
        self.y = np.vstack([self.y, [t, r, theta]])

    def __len__(self) -> int:
        return len(self.x)


@dataclasses.dataclass(frozen=True)
class Objective:
    """What to minimize: the cost of §6.2 about the target (r_d [m], theta_d [rad]) with weights w1, w2,
    and how far to trust the model (see the module docstring)."""

    r_d: float
    theta_d: float
    w1: float
    w2: float
    min_support: float = 0.5
    support_penalty: float = 200.0
    margin: float = 0.1

    def cost(self, t, r, theta):
        return placement_cost(t, r, theta, self.r_d, self.theta_d, self.w1, self.w2)


def starting_points(memory: Memory, obj: Objective, k: int = 4) -> list[int]:
    """Indices of the remembered trials with the lowest cost, time, radial error and tangential error,
    kept distinct (§6.2)."""
    t, r, th = memory.y.T
    keys = (obj.cost(t, r, th), t, np.abs(obj.r_d - r), obj.r_d * np.abs(obj.theta_d - th))
    chosen: list[int] = []
    for key in keys[:k]:
        for i in np.argsort(key, kind="stable"):
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

    ``lower``/``upper`` (original units) bound the search besides the data's box plus ``margin``."""
    model = LWR(memory.x, memory.y)
    lo_n = np.full(memory.x.shape[1], -obj.margin)
    hi_n = np.full(memory.x.shape[1], 1.0 + obj.margin)
    if lower is not None:
        lo_n = np.maximum(lo_n, model.normalize(lower))
    if upper is not None:
        hi_n = np.minimum(hi_n, model.normalize(upper))
    const = model.x.max(axis=0) == model.x.min(axis=0)
    lo_n[const], hi_n[const] = 0.0, 0.0

    def predicted(qn: np.ndarray) -> float:
        p = model.predict_normalized(np.clip(qn, lo_n, hi_n))
        c = float(obj.cost(*p.y))
        return c + obj.support_penalty * max(obj.min_support - p.support, 0.0)

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
