"""Global regression, batch (eq. 19) and recursive (eq. 22) (Singh 1995 §5.2.3.1)."""

from __future__ import annotations

import numpy as np

from excavsim.errors import ConfigError
from excavsim.learning.bases import Basis
from excavsim.learning.encoding import Samples
from excavsim.learning.model import BasisModel, check_forces

class GlobalRegression(BasisModel):
    """One linear model over the whole input space: ``F = [G 1] K`` for each of F_x, F_z.

    The batch fit solves the normal equations (eq. 19) by least squares; :meth:`update`, and
    :meth:`fit` when ``recursive``, run recursive least squares (eq. 22), one sample at a time::

        K_k = K_{k-1} + R (Y_k - K_{k-1} X_k),   R = P X_k / (lambda + X_k' P X_k),
        P  <- (P - R X_k' P) / lambda

    ``P`` is the inverse of the (forgetting-weighted) ``G'G``: kept from a batch fit, so that
    updates continue it exactly, or ``prior_scale * I`` before any data (a vague prior). The basis
    functions are standardized by the first batch's mean and spread (the fit is the same; the
    system is better conditioned); a constant term is added (the thesis' Table 2 has none, but the
    elevations of the naive basis, eq. 15, only make sense with one).

    Args:
        basis: the basis or its name.
        recursive: ``fit`` by eq. 22 from the prior instead of eq. 19.
        forgetting: ``lambda`` in (0, 1]; below 1, old samples count less (a soil that changes).
        prior_scale: the prior ``P = prior_scale I``.
    """

    def __init__(self, basis: str | Basis = "mechanics", *, recursive: bool = False, forgetting: float = 1.0,
                 prior_scale: float = 1.0e6):
        super().__init__(basis)
        if not 0.0 < forgetting <= 1.0:
            raise ConfigError(f"forgetting must lie in (0, 1]; given {forgetting!r}")
        self.name = "global regression" + (" (recursive, eq. 22)" if recursive else "")
        self.recursive = recursive
        self.forgetting = float(forgetting)
        self.prior_scale = float(prior_scale)
        self.k: np.ndarray | None = None
        self.p: np.ndarray | None = None

    @property
    def fitted(self) -> bool:
        return self.k is not None

    @property
    def nbytes(self) -> int:
        return 0 if self.k is None else int(self.k.nbytes + self._mu.nbytes + self._sd.nbytes)

    def _g(self, x: np.ndarray) -> np.ndarray:
        return np.concatenate([(x - self._mu) / self._sd, np.ones(x.shape[:-1] + (1,))], axis=-1)

    def _start(self, x: np.ndarray) -> None:
        self._mu = x.mean(axis=0)
        sd = x.std(axis=0)
        self._sd = np.where(sd > 1e-12, sd, 1.0)
        d = x.shape[1] + 1
        self.k = np.zeros((d, 2))
        self.p = self.prior_scale * np.eye(d)

    def fit_inputs(self, x: np.ndarray, y: np.ndarray) -> GlobalRegression:
        self._start(x)
        if self.recursive:
            return self._rls(x, y)
        g = self._g(x)
        self.k = np.linalg.lstsq(g, y, rcond=None)[0]
        self.p = np.linalg.pinv(g.T @ g)
        return self

    def update(self, samples: Samples, forces: np.ndarray) -> GlobalRegression:
        x, y = self._inputs(samples), check_forces(forces)
        if self.k is None:
            self._start(x)
        return self._rls(x, y)

    def _rls(self, x: np.ndarray, y: np.ndarray) -> GlobalRegression:
        lam = self.forgetting
        k, p = self.k, self.p
        for g, yk in zip(self._g(x), y):  # eq. 22, sample by sample
            pg = p @ g
            r = pg / (lam + g @ pg)
            k = k + np.outer(r, yk - g @ k)
            p = (p - np.outer(r, pg)) / lam
        self.k, self.p = k, 0.5 * (p + p.T)
        return self

    def predict_inputs(self, x: np.ndarray) -> np.ndarray:
        return self._g(x) @ self.k

    def weights(self) -> np.ndarray:
        """(D + 1, 2) coefficients of the raw basis functions and the constant (cf. Table 2)."""
        self._check_fitted()
        w = self.k[:-1] / self._sd[:, None]
        return np.concatenate([w, (self.k[-1] - self._mu @ w)[None]], axis=0)
