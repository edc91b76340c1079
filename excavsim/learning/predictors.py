"""Learned force predictors (Singh 1995 §5.2.1, §5.2.3) behind one interface.

Every :class:`ForceModel` maps force samples (columns of :mod:`excavsim.learning.encoding`, any
shape ``(...)``) to the force the wrist sensor will read, ``(..., 2)`` = ``(F_x, F_z)`` in the tip
frame [N], and learns from measured samples:

* :meth:`~ForceModel.fit` trains on a batch, :meth:`~ForceModel.predict` is vectorized over any
  number of samples (the planner's candidate digs), :meth:`~ForceModel.update` folds in new
  data (after every dig in the loop), each method as cheaply as it allows (Table 5's "ease of
  incorporating new data").
* Predictions are finite for any finite input, also far outside the training data: memory-based
  methods clamp queries to the box of their data, the net's hidden units saturate, global
  regression extrapolates linearly, the wedge model clips the rake to its domain.

Methods: :class:`WedgeModel` (eq. 8 with c, phi, delta, gamma fitted by bounded nonlinear least
squares, §5.2.1, or nominal), :class:`GlobalRegression` (eq. 19 in batch, eq. 22 recursively),
:class:`NearestNeighbours` (the mean of the 3 nearest), :class:`LocallyWeightedRegression` (eqs.
23-24, kernel width by cross-validation, optional scaling of the inputs by importance) and
:class:`NeuralNet` (one hidden layer of 30 sigmoid units, eqs. 26-27).
"""

from __future__ import annotations

from excavsim.errors import ConfigError
from excavsim.learning.bases import Basis, get_basis
from excavsim.learning.memory import LWR_WIDTHS, LocallyWeightedRegression, NearestNeighbours, importance
from excavsim.learning.model import BasisModel, ForceModel
from excavsim.learning.net import NeuralNet
from excavsim.learning.regression import GlobalRegression
from excavsim.learning.wedge_fit import WEDGE_BOUNDS, WedgeModel

__all__ = ["LWR_WIDTHS", "METHODS", "METHOD_LABELS", "WEDGE_BOUNDS", "BasisModel", "ForceModel", "GlobalRegression",
           "LocallyWeightedRegression", "NearestNeighbours", "NeuralNet", "WedgeModel", "importance", "make_model"]

METHODS = ("global", "global_rls", "nn3", "lwr", "lwr_scaled", "net")
METHOD_LABELS = {"global": "Global regression", "global_rls": "Global regression (recursive, eq. 22)",
                 "nn3": "3 nearest neighbours", "lwr": "LWR (CV width)", "lwr_scaled": "LWR (importance scaling)",
                 "net": "Back propagation (30 HU)"}


def make_model(method: str, basis: str | Basis = "mechanics", *, seed: int = 0, forgetting: float = 1.0) -> ForceModel:
    """A fresh model of a generic method on a basis (``forgetting``: of the global regressions, eq. 22).

    Raises:
        ExcavsimError: an unknown method or basis; the message lists them.
    """
    basis = get_basis(basis)
    makers = {
        "global": lambda: GlobalRegression(basis, forgetting=forgetting),
        "global_rls": lambda: GlobalRegression(basis, recursive=True, forgetting=forgetting),
        "nn3": lambda: NearestNeighbours(basis, k=3),
        "lwr": lambda: LocallyWeightedRegression(basis, seed=seed),
        "lwr_scaled": lambda: LocallyWeightedRegression(basis, scaling="importance", seed=seed),
        "net": lambda: NeuralNet(basis, seed=seed),
    }
    if method not in makers:
        raise ConfigError(f"unknown learning method {method!r}; available: {', '.join(METHODS)}")
    return makers[method]()
