"""Truck loading (Rowe 1997 §4.3, §5, §6.2): LWR, the simplex, the pile. The script itself (its coupled
trigger, the timing model) is tested in tests/execution/test_rowe_script.py."""

from __future__ import annotations

import math

import numpy as np
import pytest

from excavsim.learning.lwr_tuning import (LWR, WIDTHS, Memory, Objective, placement_cost, select_action,
                                          starting_points, svd_solve)


def _local_linear_data(n=40, seed=0):
    """y = 2 + 3 x0 - x1 near the origin, bending away from it (a known local linear model)."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1.0, 1.0, (n, 2))
    y = 2.0 + 3.0 * x[:, 0] - x[:, 1] + 4.0 * x[:, 0] ** 2 * x[:, 1] ** 2
    return x, y


def test_svd_solve_is_least_squares_and_copes_with_a_singular_matrix():
    z = np.array([[1.0, 2.0], [2.0, 4.0], [3.0, 6.0]])  # rank 1
    v = np.array([1.0, 2.0, 3.0])
    beta = svd_solve(z, v)
    assert np.allclose(z @ beta, v)
    assert np.allclose(beta, np.linalg.pinv(z) @ v)  # the minimum-norm solution
    full = np.random.default_rng(1).normal(size=(6, 3))
    assert np.allclose(svd_solve(full, full @ [1.0, -2.0, 0.5]), [1.0, -2.0, 0.5])


def test_lwr_weights_and_solve_are_the_thesis_equations():
    x, y = _local_linear_data()
    m = LWR(x, y[:, None], width=0.25)
    q = np.array([0.1, -0.2])
    qn = m.normalize(q)
    w = np.exp(-np.sum((m.xn - qn) ** 2, axis=1) / 0.25)  # w_i = exp(-D^2 / W)
    xa = np.hstack([m.xn, np.ones((len(x), 1))])
    beta = np.linalg.lstsq(w[:, None] * xa, w * y, rcond=None)[0]  # Z = W X, v = W y, Z beta = v
    p = m.predict(q)
    assert p.y[0] == pytest.approx(np.append(qn, 1.0) @ beta, rel=1e-10)
    assert p.support == pytest.approx(w.sum())


def test_lwr_recovers_the_local_linear_model_and_loo_picks_a_narrow_width():
    x, y = _local_linear_data(n=200)
    m = LWR(x, y[:, None])
    assert set(m.loo_errors) == set(WIDTHS)
    assert m.width == min(m.loo_errors, key=m.loo_errors.get)
    assert m.width < 0.5  # the bend makes the widest kernel worse than a local one
    assert m.loo_errors[m.width] < m.loo_errors[0.5]
    # the local model at the origin: slope 3 and -1 in the original units, value 2
    p = m.predict(np.zeros(2))
    assert p.y[0] == pytest.approx(2.0, abs=0.05)
    eps = 1e-3
    dx0 = (m.predict(np.array([eps, 0.0])).y[0] - m.predict(np.array([-eps, 0.0])).y[0]) / (2 * eps)
    assert dx0 == pytest.approx(3.0, abs=0.2)
    # on exactly linear data every width fits perfectly
    lin = LWR(x, (2.0 + 3.0 * x[:, 0] - x[:, 1])[:, None])
    assert max(lin.loo_errors.values()) < 1e-12


def test_nelder_mead_finds_the_minimum_of_a_known_cost_through_the_model():
    rng = np.random.default_rng(3)
    x = rng.uniform(0.0, 1.0, (30, 2))
    r_d, th_d = 1.7, math.radians(35.0)
    # outcomes linear in the action: t = 3 + x0, r = 1.2 + x1, theta = th_d (known); the cost's minimum
    # over [0, 1]^2 is at x0 = 0 (time) and x1 = 0.5 (r = r_d)
    t, r, th = 3.0 + x[:, 0], 1.2 + x[:, 1], np.full(30, th_d)
    mem = Memory(2)
    for xi, ti, ri, hi in zip(x, t, r, th):
        mem.add(xi, ti, ri, hi)
    obj = Objective(r_d, th_d, w1=5.0, w2=1696.0, margin=0.0)
    starts = starting_points(mem, obj)
    assert len(starts) == 4 and len(set(starts)) == 4
    assert starts[0] == int(np.argmin(placement_cost(t, r, th, r_d, th_d, 5.0, 1696.0)))
    sel = select_action(mem, obj, lower=np.zeros(2), upper=np.ones(2))
    assert sel.x[0] == pytest.approx(0.0, abs=0.02)
    assert sel.x[1] == pytest.approx(0.5, abs=0.01)
    assert sel.predicted_cost == pytest.approx(5.0 * 3.0, abs=0.2)


def test_the_measured_pile_is_the_true_peak_within_a_cell():
    from excavsim.tasks.dump_trial.trial import BoxMapper, pile_position, true_pile
    from excavsim.world.simulation import Simulation
    world = Simulation(seed=2)
    scanner = BoxMapper(world, 2)
    before_map = scanner.map()
    before = world.soil.grid.heights.copy()
    x, y = 1.7 * math.cos(math.radians(35.0)), 1.7 * math.sin(math.radians(35.0))
    world.soil.grid.deposit(np.array([x]), np.array([y]), np.array([0.02]), radius_m=0.15)
    world.settle_soil()
    pile = pile_position(before_map, scanner.map(), 0.0)
    true = true_pile(world, before, 0.0)
    cell = before_map.cell
    assert math.hypot(pile.x - true.x, pile.y - true.y) <= cell * math.sqrt(2) + 1e-9
    assert math.hypot(true.x - x, true.y - y) <= 2 * cell


def test_the_pile_position_moves_below_the_cell_size():
    """The weighted centre of the deposit's peak region follows a pile moved by a fraction of a cell
    (the highest cell alone would move in whole 5 cm steps)."""
    from excavsim.tasks.dump_trial.trial import deposit_peak
    cell = 0.05
    x = np.arange(0.5, 2.5, cell) + cell / 2
    y = np.arange(0.0, 1.5, cell) + cell / 2
    xx, yy = np.meshgrid(x, y)
    before = np.zeros_like(xx)
    for dx in (0.0, 0.01, 0.02, 0.035):
        cx, cy = 1.40 + dx, 0.97 - dx / 2  # off the cell centres
        after = 0.05 * np.maximum(1.0 - np.hypot(xx - cx, yy - cy) / 0.18, 0.0)  # a cone of soil
        p = deposit_peak(x, y, before, after, 0.0)
        assert math.hypot(p.x - cx, p.y - cy) < 0.2 * cell


def test_a_failed_trial_costs_high_is_never_a_start_and_steers_the_simplex_away():
    """§5.4.1: a failed trial (e.g. soil left in the bucket) is stored with a very high cost; the model
    learns where failures are and the simplex does not go there, and a failed trial is no starting point."""
    rng = np.random.default_rng(5)
    x = rng.uniform(0.0, 1.0, (30, 2))
    r_d, th_d = 1.7, math.radians(35.0)
    # time falls with x0, the placement is perfect everywhere, but x0 > 0.6 fails
    t, failed = 3.0 - x[:, 0], (x[:, 0] > 0.6).astype(float)
    mem = Memory(2)
    for xi, ti, fi in zip(x, t, failed):
        mem.add(xi, ti, r_d, th_d, fi)
    obj = Objective(r_d, th_d, w1=5.0, w2=1696.0, margin=0.0, failure_cost=500.0)
    assert obj.cost(3.0, r_d, th_d, 1.0) == pytest.approx(15.0 + 500.0)
    starts = starting_points(mem, obj)
    assert not any(failed[i] for i in starts)  # not even the lowest time, which failed
    sel = select_action(mem, obj, lower=np.zeros(2), upper=np.ones(2))
    assert sel.x[0] < 0.65 and sel.prediction.y[3] < 0.5


def test_the_prediction_error_grows_away_from_the_data():
    """The standard error comes from the leave-one-out residuals and grows with the query's leverage."""
    rng = np.random.default_rng(2)
    x = rng.uniform(0.0, 1.0, (40, 2))
    y = 1.0 + x[:, 0] + rng.normal(0.0, 0.1, 40)
    m = LWR(x, y[:, None])
    assert m.loo_mse[0] == pytest.approx(0.01, rel=0.6)
    inside, outside = m.predict(np.array([0.5, 0.5])), m.predict(np.array([1.6, 1.6]))
    assert inside.stderr[0] == pytest.approx(0.1, rel=0.6)
    assert outside.stderr[0] > inside.stderr[0] and outside.support < inside.support


def test_a_trial_is_a_task_of_the_episode_and_takes_no_dig_source():
    from excavsim.errors import ExcavsimError
    from excavsim.loop.episode import Episode
    from excavsim.tasks.dump_trial.trial import TruckTask, load_truck_config, nominal_params

    cfg = load_truck_config()
    task = TruckTask(nominal_params(cfg), cfg)
    with pytest.raises(ExcavsimError, match="no dig source can be given"):
        Episode(task, dig_budget=1).reset(0, digs=object())
    assert task.final_scan is False and task.budget_reason(1) == "the trial's script ran"
