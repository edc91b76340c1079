"""Comparing force predictors as §5.2.4 does: Table 4 (accuracy), Table 5 (cost), Fig. 81 (large forces).

Accuracy is the mean absolute error between the predicted and the observed **magnitude** of the
force, over a 10-fold cross-validation: the samples are shuffled and split into ten blocks of
near-equal size; each block in turn is predicted by a model trained on the other nine
(§5.2.4.5). ``by_dig=True`` splits by whole digs instead, which is harder (a dig's samples are
alike) and closer to predicting a new dig. Costs are measured on the whole data set: training
time, prediction time for one query and per sample of a planner-sized batch, and the memory a
model needs to predict.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence

import numpy as np

from excavsim.config import SoilParams
from excavsim.learning.bases import BASES, get_basis
from excavsim.learning.dataset import ForceDataset
from excavsim.learning.predictors import METHOD_LABELS, METHODS, ForceModel, WedgeModel, make_model

WEDGE_METHODS = ("wedge_nominal", "wedge_fit")
LABELS = {"wedge_nominal": "Wedge model (nominal soil)", "wedge_fit": "Wedge model (fitted c, phi, delta, gamma)",
          **METHOD_LABELS}
EASE = {"wedge_nominal": "none (fixed soil)", "wedge_fit": "complete refit", "global": "iterative (eq. 22)",
        "global_rls": "iterative (eq. 22)", "nn3": "easy: store it", "lwr": "easy: store it",
        "lwr_scaled": "easy: store it", "net": "some retraining"}
LARGE_FORCE_N = 300.0  # Fig. 81: samples whose observed |F_x| or |F_z| exceeds this


@dataclasses.dataclass
class CVResult:
    """Cross-validated accuracy of one method on one basis (None for the wedge model).

    ``predictions`` (n, 2) are the out-of-fold predictions of every sample [N].
    """

    method: str
    basis: str | None
    mae: float
    mae_x: float
    mae_z: float
    predictions: np.ndarray
    seconds: float

    @property
    def label(self) -> str:
        return LABELS[self.method]


def magnitude(forces: np.ndarray) -> np.ndarray:
    """|F| (...) of forces (..., 2) [N]."""
    return np.hypot(forces[..., 0], forces[..., 1])


def fold_indices(data: ForceDataset, folds: int = 10, *, seed: int = 0, by_dig: bool = False) -> list[np.ndarray]:
    """Test indices of each fold: shuffled samples (or whole digs) in ``folds`` near-equal blocks."""
    rng = np.random.default_rng(seed)
    if not by_dig:
        return [np.sort(b) for b in np.array_split(rng.permutation(len(data)), folds)]
    digs = rng.permutation(np.unique(data["dig"]))
    return [np.nonzero(np.isin(data["dig"], b))[0] for b in np.array_split(digs, folds)]


def _model(method: str, basis: str | None, soil: SoilParams, width: float, seed: int) -> ForceModel:
    if method == "wedge_nominal":
        return WedgeModel(soil, width, fit_params=False)
    if method == "wedge_fit":
        return WedgeModel(soil, width, seed=seed)
    return make_model(method, basis, seed=seed)


def cross_validate(data: ForceDataset, *, soil: SoilParams, width: float, methods: Sequence[str] = METHODS,
                   bases: Sequence[str] = tuple(BASES), wedge: bool = True, folds: int = 10, seed: int = 0,
                   by_dig: bool = False, progress: Callable[[str], None] | None = None) -> list[CVResult]:
    """Out-of-fold accuracy of every method on every basis (and of the wedge model, nominal and fitted).

    Args:
        data: the force data set.
        soil: the nominal soil (the wedge model's, and the first start of its fit).
        width: bucket width [m].
        methods: generic methods (``METHODS``); bases: basis names.
        wedge: also evaluate the wedge model (it has no basis).
        folds: number of blocks; seed: seeds the split; by_dig: split by whole digs.
        progress: called with a line per method and basis.
    """
    say = progress or (lambda _s: None)
    test_sets = fold_indices(data, folds, seed=seed, by_dig=by_dig)
    y = data.forces
    runs = [(m, None) for m in (WEDGE_METHODS if wedge else ())] + [(m, b) for m in methods for b in bases]
    out = []
    for method, basis in runs:
        t0 = time.perf_counter()
        pred = np.zeros_like(y)
        for test in test_sets:
            train = np.setdiff1d(np.arange(len(data)), test)
            model = _model(method, basis, soil, width, seed)
            model.fit(data.subset(train).samples, y[train])
            pred[test] = model.predict(data.subset(test).samples)
        err = np.abs(pred - y)
        res = CVResult(method, basis, float(np.mean(np.abs(magnitude(pred) - magnitude(y)))), float(err[:, 0].mean()),
                       float(err[:, 1].mean()), pred, time.perf_counter() - t0)
        out.append(res)
        say(f"  {res.label:<42} {basis or '':<10} MAE |F| {res.mae:6.1f} N  (F_x {res.mae_x:5.1f}, "
            f"F_z {res.mae_z:5.1f})  [{res.seconds:.1f} s]")
    return out


def format_table4(results: Sequence[CVResult], data: ForceDataset, *, folds: int = 10,
                  beside: Sequence[CVResult] | None = None) -> str:
    """Table 4: mean absolute error of |F| by method (rows) and basis (columns).

    With ``beside`` (the same methods under another protocol) each cell shows both, ``results``
    first and ``beside`` in parentheses: whole digs held out, the primary figure, with the thesis'
    shuffled samples beside it.
    """
    bases = [b for b in BASES if any(r.basis == b for r in results)]
    heads = [f"{b.capitalize()} (eq. {get_basis(b).equation})" for b in bases]
    soil = data.meta.get("soil", "?")
    other = {(r.method, r.basis): r.mae for r in beside} if beside is not None else {}

    def cell(method, basis, mae):
        if beside is None:
            return f"{mae:>22.1f}"
        return f"{mae:>13.1f} ({other.get((method, basis), float('nan')):5.1f})"

    lines = [f"Table 4  Mean absolute error [N] between predicted and observed magnitude of the force "
             f"({folds}-fold cross-validation; {len(data)} samples of {data.n_digs} digs in {soil}; "
             f"mean observed |F| {magnitude(data.forces).mean():.0f} N)",
             f"{'':<42}" + "".join(f"{h:>22}" for h in heads)]
    for method in dict.fromkeys(r.method for r in results if r.basis is not None):
        row = {r.basis: r.mae for r in results if r.method == method}
        lines.append(f"{LABELS[method]:<42}" + "".join(cell(method, b, row.get(b, float("nan"))) for b in bases))
    for r in results:
        if r.basis is None:
            lines.append(f"{r.label:<42}{cell(r.method, None, r.mae)}   (no basis)")
    return "\n".join(lines)


@dataclasses.dataclass
class CostRow:
    """Table 5: one method's training time [s], prediction time [ms] and memory [bytes]."""

    method: str
    train_s: float
    query_ms: float
    batch_us: float
    nbytes: int
    ease: str


def measure_costs(data: ForceDataset, *, soil: SoilParams, width: float, basis: str = "mechanics",
                  methods: Sequence[str] = WEDGE_METHODS[1:] + METHODS, batch: int = 10_000, seed: int = 0
                  ) -> list[CostRow]:
    """Training on all of ``data``, one query, and a batch of ``batch`` planner queries, per method."""
    rng = np.random.default_rng(seed)
    queries = data.subset(rng.integers(0, len(data), batch)).samples
    one = data.subset(np.array([0])).samples
    rows = []
    for method in methods:
        model = _model(method, None if method in WEDGE_METHODS else basis, soil, width, seed)
        t0 = time.perf_counter()
        model.fit(data.samples, data.forces)
        train = time.perf_counter() - t0
        reps = 20
        t0 = time.perf_counter()
        for _ in range(reps):
            model.predict(one)
        query = (time.perf_counter() - t0) / reps
        t0 = time.perf_counter()
        model.predict(queries)
        per = (time.perf_counter() - t0) / batch
        rows.append(CostRow(method, train, 1e3 * query, 1e6 * per, model.nbytes, EASE[method]))
    return rows


def format_table5(rows: Sequence[CostRow], *, basis: str = "mechanics", batch: int = 10_000) -> str:
    """Table 5: training time, prediction time, ease of incorporating new data, memory."""
    lines = [f"Table 5  Costs on the whole data set ({basis} basis); prediction: one query, and per sample of a "
             f"batch of {batch} (a planner's candidates)",
             f"{'':<42}{'training s':>11}{'query ms':>10}{'batch us':>10}{'memory kB':>11}   new data"]
    for r in rows:
        lines.append(f"{LABELS[r.method]:<42}{r.train_s:>11.2f}{r.query_ms:>10.2f}{r.batch_us:>10.2f}"
                     f"{r.nbytes / 1024:>11.1f}   {r.ease}")
    return "\n".join(lines)


def large_force_errors(results: Sequence[CVResult], data: ForceDataset, *, threshold: float = LARGE_FORCE_N
                       ) -> dict[str, np.ndarray]:
    """Errors ``|F|_predicted - |F|_observed`` [N] of the samples whose observed |F_x| or |F_z| exceeds
    ``threshold`` (Fig. 81; negative: the force was underestimated), per result label."""
    y = data.forces
    big = np.any(np.abs(y) > threshold, axis=1)
    return {f"{r.label}" + (f" ({r.basis})" if r.basis else ""): magnitude(r.predictions[big]) - magnitude(y[big])
            for r in results}
