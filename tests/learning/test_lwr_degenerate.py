"""The tuner's LWR (Rowe 1997 §6.2) where the data cannot support a fit: a query far from every point, whose
kernel weights underflow, and a memory whose leave-one-out fits have no neighbours. The prediction must
be finite and say it is unsupported (an infinite standard error), never NaN (Atkeson, Moore & Schaal 1997)."""

import math
import warnings

import numpy as np
import pytest

from excavsim.learning.lwr_tuning import LWR, Memory, Objective, select_action, svd_solve


@pytest.fixture(autouse=True)
def _numpy_warnings_are_errors():
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        yield


def _linear(m: int = 7, n: int = 12, seed: int = 0):
    """n points in [0, 1]^m (the memory's box is exactly [0, 1]^m) and 2 exactly linear outputs."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(0.0, 1.0, (n, m))
    x[0], x[1] = 0.0, 1.0
    b = rng.normal(size=(m, 2))
    return x, np.array([1.0, -2.0]) + x @ b, b


def test_svd_solve_of_a_subnormal_matrix_is_finite():
    z = np.array([[1e-310, 0.0], [0.0, 3e-320], [2e-310, 1e-321]])
    beta = svd_solve(z, np.array([1e-310, 2e-320, 0.0]))
    assert np.all(np.isfinite(beta))


# the largest weight 1e-70 (its 4th power in the error underflows), 1e-281 (its square in Z^T Z), 0
@pytest.mark.parametrize("far", [1.3, 1.6, 3.0])
def test_a_query_far_from_the_data_is_finite_and_unsupported(far):
    x, y, _ = _linear()
    m = LWR(x, y, width=2.0 ** -8)
    q = np.full(7, far)
    p = m.predict(q)
    assert np.all(np.isfinite(p.y))
    # the weighted fit is unchanged by a common factor of the weights: it is the fit of the weights
    # relative to the nearest point's (the SVD's truncation at rcond 1e-8), not 0 (all weights underflowed)
    d2 = np.sum((x - q) ** 2, axis=1)
    w_rel = np.exp(-(d2 - d2.min()) / 2.0 ** -8)
    xa = np.hstack([x, np.ones((len(x), 1))])
    beta = np.linalg.lstsq(w_rel[:, None] * xa, w_rel[:, None] * y, rcond=1e-8)[0]
    assert p.y == pytest.approx(np.append(q, 1.0) @ beta, rel=1e-9)
    assert np.all(np.abs(p.y) > 0.1)
    assert p.support < 1e-60 and np.all(np.isinf(p.stderr))  # the data cannot support it: error unknown


def test_a_supported_query_keeps_its_finite_error_and_the_fit_of_the_absolute_weights():
    x, y, _ = _linear(m=2, n=40, seed=3)
    m = LWR(x, y, width=0.25)
    q = np.array([0.4, 0.6])
    p = m.predict(q)
    w = np.exp(-np.sum((x - q) ** 2, axis=1) / 0.25)
    xa = np.hstack([x, np.ones((len(x), 1))])
    beta = np.linalg.lstsq(w[:, None] * xa, w[:, None] * y, rcond=None)[0]
    assert p.y == pytest.approx(np.append(q, 1.0) @ beta, rel=1e-12)
    assert p.support == pytest.approx(w.sum()) and np.all(np.isfinite(p.stderr))


def test_an_isolated_trial_gives_finite_loo_errors_and_the_simplex_a_finite_action():
    """A guard: a memory like the tuner's first trials, a cluster and one trial at the far corner of the box;
    at the narrow widths the isolated trial's leave-one-out fit has no weight left."""
    rng = np.random.default_rng(4)
    x = np.vstack([rng.uniform(0.0, 0.05, (5, 7)), np.ones(7)])
    mem = Memory(7)
    for xi in x:
        mem.add(xi, 20.0 + xi.sum(), 7.7 - 0.1 * xi[0], math.radians(90.0) + 0.01 * xi[1])
    m = LWR(mem.x, mem.y, width_outputs=3)
    assert all(math.isfinite(e) for e in m.loo_errors.values())
    assert np.all(np.isfinite(m.loo_mse))
    obj = Objective(7.7, math.radians(90.0), w1=5.0, w2=1696.0, trust_radius=0.25)
    sel = select_action(mem, obj, maxiter=200)
    assert np.all(np.isfinite(sel.x)) and math.isfinite(sel.predicted_cost)
    assert np.all(np.isfinite(sel.prediction.y))


def test_trials_whose_weights_at_each_other_are_subnormal_give_a_finite_leave_one_out_error():
    """Two trials at opposite corners and a kernel so narrow that each one's weight at the other is a
    subnormal number (exp(-720)): each left-out trial's fit used to be NaN, and so its error."""
    x = np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]])
    y = np.array([[20.0, 7.5, 1.5], [24.0, 7.9, 1.6]])
    m = LWR(x, y, width=3.0 / 720.0)
    assert np.all(np.isfinite(m.loo_mse)) and np.all(m.loo_mse > 0)
    p = m.predict(np.array([0.5, 0.5, 0.5]))
    assert np.all(np.isfinite(p.y)) and np.all(np.isinf(p.stderr))
