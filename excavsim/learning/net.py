"""A back-propagation network predicting forces (Singh 1995 §5.2.3.3, eqs. 26-27)."""

from __future__ import annotations

import warnings

import numpy as np

from excavsim.learning.bases import Basis
from excavsim.learning.encoding import Samples
from excavsim.learning.model import BasisModel, check_forces

class NeuralNet(BasisModel):
    """One hidden layer of sigmoid units (eqs. 26-27), scikit-learn's ``MLPRegressor``.

    Inputs and outputs are standardized by the training data; the net is trained by L-BFGS with an
    L2 penalty that keeps it from fitting the digs it saw at the expense of new ones (the thesis
    presented the data 10,000 times by back-propagation; Fig. 74 chose 30 hidden units).
    :meth:`update` retrains from the current weights on all data seen ("some retraining
    required", Table 5).

    Args:
        basis: the basis or its name.
        hidden: hidden units.
        max_iter: training iterations of a fit (an update runs a tenth of them).
        alpha: L2 penalty on the weights.
        seed: seeds the initial weights.
    """

    def __init__(self, basis: str | Basis = "mechanics", *, hidden: int = 30, max_iter: int = 300,
                 alpha: float = 0.5, seed: int = 0):
        super().__init__(basis)
        self.name = f"back propagation ({hidden} HU)"
        self.hidden = int(hidden)
        self.max_iter = int(max_iter)
        self.alpha = float(alpha)
        self.seed = seed
        self.net = None

    @property
    def fitted(self) -> bool:
        return self.net is not None

    @property
    def nbytes(self) -> int:
        if self.net is None:
            return 0
        arrays = list(self.net.coefs_) + list(self.net.intercepts_) + [self._mu, self._sd, self._ymu, self._ysd]
        return int(sum(a.nbytes for a in arrays))

    def fit_inputs(self, x: np.ndarray, y: np.ndarray, *, warm: bool = False) -> NeuralNet:
        from sklearn.exceptions import ConvergenceWarning
        from sklearn.neural_network import MLPRegressor
        from threadpoolctl import threadpool_limits  # a dependency of scikit-learn

        self._x, self._y = x, y
        if not warm or self.net is None:
            self._mu, sd = x.mean(axis=0), x.std(axis=0)
            self._sd = np.where(sd > 1e-12, sd, 1.0)
            self._ymu, ysd = y.mean(axis=0), y.std(axis=0)
            self._ysd = np.where(ysd > 1e-12, ysd, 1.0)
            self.net = MLPRegressor(hidden_layer_sizes=(self.hidden,), activation="logistic", solver="lbfgs",
                                    alpha=self.alpha, max_iter=self.max_iter, random_state=self.seed)
        else:
            self.net.set_params(warm_start=True, max_iter=max(self.max_iter // 10, 1))
        # BLAS threads cost more than they give on matrices this small (8x slower on 2 cores)
        with warnings.catch_warnings(), threadpool_limits(1):
            warnings.simplefilter("ignore", ConvergenceWarning)
            self.net.fit((x - self._mu) / self._sd, (y - self._ymu) / self._ysd)
        return self

    def update(self, samples: Samples, forces: np.ndarray) -> NeuralNet:
        x, y = self._inputs(samples), check_forces(forces)
        if self.net is None:
            return self.fit_inputs(x, y)
        return self.fit_inputs(np.concatenate([self._x, x]), np.concatenate([self._y, y]), warm=True)

    def predict_inputs(self, x: np.ndarray) -> np.ndarray:
        out = self.net.predict((x - self._mu) / self._sd).reshape(len(x), 2)
        return out * self._ysd + self._ymu
