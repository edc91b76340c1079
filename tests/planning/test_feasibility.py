"""The feasibility of grid cells and their longest admissible drag (ch. 4-6), shared by plan and anneal."""

from __future__ import annotations

import numpy as np
import pytest

from excavsim import constants
from excavsim.config import get_soil, load_planner_config, load_trench_goal
from excavsim.handoff.maps import ElevationMap
from excavsim.planning.feasibility import NO_DIG, prune_along_d1
from excavsim.planning.predictor import WedgePredictor
from excavsim.planning.search import TrenchPlanner

WEAK_WRIST_NM = 250.0  # the nominal sand forces need up to about 350 N m at the wrist on this trench


@pytest.fixture(scope="module")
def setting(arm, reach_table):
    """The straight trench in testbed sand on the flat 0.5 m fill: planner, surface, the grid's cells."""
    soil = get_soil("testbed_sand")
    planner = TrenchPlanner(arm, reach_table, np.array([25000.0, 12000.0, 1000.0]), 0.3, 0.0203981,
                            load_trench_goal(constants.TRENCHES_DIR / "straight.yaml"), load_planner_config(),
                            WedgePredictor(soil, 0.3), soil.density_kg_m3)
    emap = ElevationMap(0.55, -1.5, 0.05, np.full((60, 60), 0.5), np.ones((60, 60), bool), 0.0)
    surface = planner.surface(emap)
    return planner, surface, planner.grid_cells()


def test_pruning_along_d1_stops_at_the_first_goal_cutting_penetration():
    """§6.2.1: along d1 every penetration after the first one through the goal contains it."""
    ok = np.array([[[True, True, False, True]], [[False, True, True, True]], [[True, True, True, True]]])
    alive = prune_along_d1(ok.ravel(), ok.shape)
    np.testing.assert_array_equal(alive.reshape(ok.shape), [[[1, 1, 0, 0]], [[0, 0, 0, 0]], [[1, 1, 1, 1]]])


def test_penetrations_judged_per_cell_agree_with_the_lines_shared_along_d1(setting):
    planner, surface, (k, alpha, d1) = setting
    feas = planner.feasibility(surface, planner.cfg.fill_fraction * planner.capacity)
    lines = feas.penetration_lines(planner.grid_k, planner.grid_alpha, planner.grid_d1, k, alpha, d1)
    cells = feas.penetrations(planner.penetrate(k, alpha, d1, surface), prune=False)
    for name in ("shaping", "sensible", "reachability", "force"):
        np.testing.assert_array_equal(getattr(lines, name), getattr(cells, name), err_msg=name)
    assert 0 < lines.shaping.mean() < 1 and 0 < lines.reachability.mean() < 1  # both verdicts occur
    np.testing.assert_allclose(lines.volume, cells.volume, rtol=1e-9, atol=1e-15)
    reach = lines.reachability
    np.testing.assert_allclose(lines.peak[reach], cells.peak[reach], rtol=1e-9)
    np.testing.assert_allclose(lines.cum[reach], cells.cum[reach], rtol=1e-9)
    assert lines.samples < cells.samples  # the point of sharing


def test_a_cell_is_judged_the_same_alone_or_in_a_batch(setting):
    planner, surface, (k, alpha, d1) = setting
    vmax = planner.cfg.fill_fraction * planner.capacity
    cells = np.linspace(0, k.size - 1, 40).astype(int)
    pen = planner.penetrate(k[cells], alpha[cells], d1[cells], surface)
    batch = planner.evaluate_cells(pen, planner.drag(pen[:, -1]), surface, vmax)
    assert (batch.j == NO_DIG).any() and (batch.j > 0).any()
    for i in range(cells.size):
        one = planner.evaluate_cells(pen[i:i + 1], planner.drag(pen[i:i + 1, -1]), surface, vmax)
        assert one.j[0] == batch.j[i] and one.radius[0] == batch.radius[i]
        for key in ("volume", "peak", "cum"):
            np.testing.assert_array_equal(getattr(one, key), getattr(batch, key)[i:i + 1])


def test_infinite_torque_limits_switch_the_force_constraint_off(setting):
    """What ``plan(classify_limits=True)`` relies on: the same evaluation with its limits as a parameter."""
    planner, surface, (k, alpha, d1) = setting
    vmax = planner.cfg.fill_fraction * planner.capacity
    cells = np.linspace(0, k.size - 1, 400).astype(int)
    pen = planner.penetrate(k[cells], alpha[cells], d1[cells], surface)
    drag = planner.drag(pen[:, -1])
    weak_limits = np.array([25000.0, 12000.0, WEAK_WRIST_NM])
    weak = planner.feasibility(surface, vmax, limits=weak_limits).evaluate(pen, drag, True)
    free = planner.feasibility(surface, vmax, limits=np.full(3, np.inf)).evaluate(pen, drag, True)
    assert (free.j >= 0).sum() > (weak.j >= 0).sum() > 0
    assert free.masks["force"].sum() > weak.masks["force"].sum()
    np.testing.assert_array_equal(free.masks["force"], free.masks["reachability"])  # force fails only unreachable
    np.testing.assert_array_equal(planner.limits, [25000.0, 12000.0, 1000.0])
