"""The interface of learned force predictors (Singh 1995 §5.2): :class:`ForceModel`.

A model maps force samples (columns of :mod:`excavsim.learning.encoding`, any shape ``(...)``) to
the force the wrist sensor will read, ``(..., 2)`` = ``(F_x, F_z)`` in the tip frame [N]:
:meth:`~ForceModel.fit` trains on a batch, :meth:`~ForceModel.predict` is vectorized over any
number of samples (the planner's candidate digs), :meth:`~ForceModel.update` folds in new data
(after every dig in the loop). :class:`BasisModel` is the base of the methods that work on the
terms of a :class:`~excavsim.learning.bases.Basis`.
"""

from __future__ import annotations

import abc

import numpy as np

from excavsim.errors import UsageError
from excavsim.learning.bases import Basis, get_basis
from excavsim.learning.encoding import Samples


class ForceModel(abc.ABC):
    """A learned predictor of the tip-frame force ``(F_x, F_z)`` (see the module docstring)."""

    name: str = "model"
    basis: Basis | None = None

    @abc.abstractmethod
    def fit(self, samples: Samples, forces: np.ndarray) -> ForceModel:
        """Train on samples (n,) and their measured forces (n, 2) [N]; returns self."""

    @abc.abstractmethod
    def predict(self, samples: Samples) -> np.ndarray:
        """Forces (..., 2) [N] for samples of any shape (...)."""

    def update(self, samples: Samples, forces: np.ndarray) -> ForceModel:
        """Fold new measured samples in (the default refits on everything seen); returns self."""
        x, y = self._stored()
        new_x, new_y = self._inputs(samples), check_forces(forces)
        if x is None:
            return self.fit_inputs(new_x, new_y)
        return self.fit_inputs(np.concatenate([x, new_x]), np.concatenate([y, new_y]))

    @property
    @abc.abstractmethod
    def fitted(self) -> bool:
        """Whether the model can predict."""

    @property
    @abc.abstractmethod
    def nbytes(self) -> int:
        """Memory the model needs to predict [bytes] (Table 5)."""

    # -- shared plumbing ----------------------------------------------------------------------------
    def _inputs(self, samples: Samples) -> np.ndarray:
        return self.basis.design(samples)

    def _stored(self) -> tuple[np.ndarray | None, np.ndarray | None]:
        return getattr(self, "_x", None), getattr(self, "_y", None)

    def fit_inputs(self, x: np.ndarray, y: np.ndarray) -> ForceModel:  # pragma: no cover - overridden
        raise NotImplementedError

    def _check_fitted(self) -> None:
        if not self.fitted:
            raise UsageError(f"{self.name}: predict before fit (train it on a ForceDataset first)")


def check_forces(forces: np.ndarray) -> np.ndarray:
    y = np.asarray(forces, dtype=float)
    if y.ndim != 2 or y.shape[1] != 2:
        raise UsageError(f"forces must be (n, 2) measured (F_x, F_z) [N]; given shape {y.shape}")
    return y


def flat_inputs(x: np.ndarray) -> tuple[np.ndarray, tuple[int, ...]]:
    return x.reshape(-1, x.shape[-1]), x.shape[:-1]


class BasisModel(ForceModel):
    """A model on the basis functions of a :class:`Basis`: ``fit`` and ``update`` go through arrays."""

    def __init__(self, basis: str | Basis):
        self.basis = get_basis(basis)

    def fit(self, samples: Samples, forces: np.ndarray) -> ForceModel:
        x, y = self._inputs(samples), check_forces(forces)
        if x.shape[:-1] != y.shape[:-1]:
            raise UsageError(f"{self.name}: {x.shape[0]} samples but {y.shape[0]} forces")
        if x.shape[0] == 0:
            raise UsageError(f"{self.name}: cannot fit on no samples")
        return self.fit_inputs(x, y)

    def predict(self, samples: Samples) -> np.ndarray:
        self._check_fitted()
        x, shape = flat_inputs(self._inputs(samples))
        return self.predict_inputs(x).reshape(shape + (2,))

    @abc.abstractmethod
    def predict_inputs(self, x: np.ndarray) -> np.ndarray:
        """(n, D) basis values -> (n, 2) forces."""
