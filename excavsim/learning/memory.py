"""Memory-based learning: nearest neighbours and locally weighted regression (§5.2.3.2, eqs. 23-25)."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from excavsim.errors import ConfigError
from excavsim.learning.bases import Basis
from excavsim.learning.encoding import Samples
from excavsim.learning.model import BasisModel, check_forces

class _MemoryModel(BasisModel):
    """Stores every sample; inputs normalized to [0, 1] by the data's range (times an optional scale)."""

    clamp_margin = 0.1  # queries are clamped to the data's box widened by this fraction of its range

    @property
    def fitted(self) -> bool:
        return getattr(self, "_tree", None) is not None

    @property
    def nbytes(self) -> int:
        return 0 if not self.fitted else int(self._z.nbytes + self._y.nbytes + self._tree.indices.nbytes)

    def _normalize(self, x: np.ndarray) -> np.ndarray:
        z = (x - self._lo) / self._span
        return np.clip(z, -self.clamp_margin, 1.0 + self.clamp_margin) * self._scale

    def _store(self, x: np.ndarray, y: np.ndarray, scale: np.ndarray | None = None) -> None:
        self._x, self._y = x, y
        self._lo = x.min(axis=0)
        span = x.max(axis=0) - self._lo
        self._span = np.where(span > 1e-12, span, 1.0)
        self._scale = np.ones(x.shape[1]) if scale is None else scale
        self._z = self._normalize(x)
        self._tree = cKDTree(self._z)


class NearestNeighbours(_MemoryModel):
    """The mean force of the ``k`` nearest stored samples (Fig. 70a); ``update`` just stores more."""

    def __init__(self, basis: str | Basis = "mechanics", *, k: int = 3):
        super().__init__(basis)
        self.k = int(k)
        self.name = f"{self.k} nearest neighbours"

    def fit_inputs(self, x: np.ndarray, y: np.ndarray) -> NearestNeighbours:
        self._store(x, y)
        return self

    def predict_inputs(self, x: np.ndarray) -> np.ndarray:
        k = min(self.k, len(self._y))
        _, idx = self._tree.query(self._normalize(x), k=k)
        return self._y[idx.reshape(len(x), k)].mean(axis=1)


LWR_WIDTHS = 2.0 ** -np.arange(1, 9)  # candidate kernel widths K_w, 2^-1 .. 2^-8 (Fig. 70)


class LocallyWeightedRegression(_MemoryModel):
    """A local linear model per query, fitted to its neighbours weighted by a Gaussian kernel.

    ``K = (G' W G)^-1 G' W F`` (eq. 23) with ``w_i = exp(-d_i^2 / 2 K_w^2)`` (eq. 24), ``d_i`` the
    distance of stored sample i to the query in normalized inputs; ``G = [1, x_i - x_q]`` so that
    the constant is the prediction. (Eq. 23 writes ``W^-1``, W being the samples' variances there;
    with the weights of eq. 24 they enter directly.) The ``neighbours`` nearest samples come from a
    k-d tree (eq. 25); weights are taken relative to the nearest one (which leaves the solution
    unchanged) so that a query far from all data still has a neighbour that counts, and a small
    ridge on the slopes turns a local model with too few effective samples into a weighted mean.

    The kernel width is chosen by 5-fold cross-validation on the training data among
    ``LWR_WIDTHS`` unless given, holding out whole digs (samples sharing ``k``, ``alpha`` and the
    terrain profile): neighbouring samples of one dig are near-duplicates, and a width chosen on
    them would fit digs seen rather than predict new ones. With ``scaling="importance"`` each
    normalized input is multiplied by its relative importance, in place of the thesis' MARS
    analysis (Table 3): the size of its standardized coefficient in a global linear fit, the
    larger of F_x's and F_z's, relative to the largest (inputs of no importance drop out of the
    distance).

    Args:
        basis: the basis or its name.
        width: the kernel width K_w (None: cross-validated).
        scaling: None (all inputs equal) or ``"importance"``.
        neighbours: samples per local model.
        ridge: ridge on the slopes, relative to the sum of the weights.
        seed: seeds the cross-validation folds.
    """

    def __init__(self, basis: str | Basis = "mechanics", *, width: float | None = None, scaling: str | None = None,
                 neighbours: int = 40, ridge: float = 1.0e-3, seed: int = 0):
        super().__init__(basis)
        if scaling not in (None, "importance"):
            raise ConfigError(f"LWR scaling must be None or 'importance'; given {scaling!r}")
        self.name = "LWR" + (" (importance scaling)" if scaling else "")
        self.width = width
        self._width_given = width is not None
        self.scaling = scaling
        self.neighbours = int(neighbours)
        self.ridge = float(ridge)
        self.seed = seed
        self.cv_errors: dict[float, float] = {}

    def fit(self, samples: Samples, forces: np.ndarray) -> LocallyWeightedRegression:
        self._groups = dig_groups(samples)
        try:
            return super().fit(samples, forces)
        finally:
            self._groups = None

    def fit_inputs(self, x: np.ndarray, y: np.ndarray) -> LocallyWeightedRegression:
        scale = importance(x, y) if self.scaling == "importance" else None
        self._store(x, y, scale)
        if not self._width_given:
            self.width, self.cv_errors = self._cross_validate_width()
        return self

    def _cross_validate_width(self, folds: int = 5, max_samples: int = 2000) -> tuple[float, dict[float, float]]:
        rng = np.random.default_rng(self.seed)
        n = len(self._y)
        groups = getattr(self, "_groups", None)
        if groups is None or len(np.unique(groups)) < folds:
            groups = np.arange(n)
        fold_of = rng.permutation(int(groups.max()) + 1)[groups] % folds
        order = rng.permutation(n)[:max_samples]
        errors = np.zeros(len(LWR_WIDTHS))
        for f in range(folds):
            test = order[fold_of[order] == f]
            train = np.nonzero(fold_of != f)[0]
            tree = cKDTree(self._z[train])
            idx, d2 = self._neighbours(tree, self._z[test], len(train))
            for w, width in enumerate(LWR_WIDTHS):
                pred = self._local(self._z[train], self._y[train], self._z[test], idx, d2, width)
                errors[w] += np.abs(pred - self._y[test]).sum()
        best = int(np.argmin(errors))
        total = max(len(order), 1)
        return float(LWR_WIDTHS[best]), {float(w): float(e / total) for w, e in zip(LWR_WIDTHS, errors)}

    def _neighbours(self, tree: cKDTree, zq: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
        k = min(self.neighbours, n)
        d, idx = tree.query(zq, k=k)
        return idx.reshape(len(zq), k), (d * d).reshape(len(zq), k)

    def _local(self, z: np.ndarray, y: np.ndarray, zq: np.ndarray, idx: np.ndarray, d2: np.ndarray,
               width: float, chunk: int = 4096) -> np.ndarray:
        out = np.empty((len(zq), 2))
        dim = z.shape[1] + 1
        reg = np.eye(dim)
        reg[0, 0] = 0.0
        for a in range(0, len(zq), chunk):
            b = min(a + chunk, len(zq))
            w = np.exp(-(d2[a:b] - d2[a:b, :1]) / (2.0 * width * width))  # relative to the nearest
            g = np.concatenate([np.ones(idx[a:b].shape + (1,)), z[idx[a:b]] - zq[a:b, None, :]], axis=-1)
            gw = g * w[..., None]
            lhs = np.einsum("mki,mkj->mij", gw, g) + self.ridge * w.sum(axis=1)[:, None, None] * reg
            rhs = np.einsum("mki,mkl->mil", gw, y[idx[a:b]])
            out[a:b] = np.linalg.solve(lhs, rhs)[:, 0, :]
        return out

    def predict_inputs(self, x: np.ndarray) -> np.ndarray:
        zq = self._normalize(x)
        idx, d2 = self._neighbours(self._tree, zq, len(self._y))
        return self._local(self._z, self._y, zq, idx, d2, self.width)

    def update(self, samples: Samples, forces: np.ndarray) -> LocallyWeightedRegression:
        """Store the new samples (the kernel width and scaling are kept once chosen)."""
        x, y = self._inputs(samples), check_forces(forces)
        if not self.fitted:
            return self.fit_inputs(x, y)
        given = self._width_given
        self._width_given = True
        try:
            scale = self._scale
            self._store(np.concatenate([self._x, x]), np.concatenate([self._y, y]), scale)
        finally:
            self._width_given = given
        return self


def dig_groups(samples: Samples) -> np.ndarray | None:
    """A group label per sample (n,): samples of one dig share its entry, angle and terrain profile."""
    cols = ("k", "alpha", "lz1", "lz3", "lz5")
    if not all(c in samples for c in cols):
        return None
    key = np.stack([np.asarray(samples[c], dtype=float).reshape(-1) for c in cols], axis=-1)
    return np.unique(key, axis=0, return_inverse=True)[1].reshape(-1)


def importance(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Relative importance (D,) in [0, 1] of each input: the size of its standardized coefficient in
    a global linear fit of each output, the larger over the outputs, relative to the largest."""
    sd = x.std(axis=0)
    z = np.where(sd > 1e-12, (x - x.mean(axis=0)) / np.where(sd > 1e-12, sd, 1.0), 0.0)
    g = np.concatenate([z, np.ones((len(z), 1))], axis=1)
    coef = np.abs(np.linalg.lstsq(g, y, rcond=None)[0][:-1]).max(axis=1)
    top = coef.max()
    return coef / top if top > 0 else np.ones_like(coef)
