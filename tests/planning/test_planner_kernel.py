"""The compiled planner kernel (planning.kernel) gives the vectorized reference's answer, cell by cell.

On several maps (flat, a partly dug trench, bumps and noise, the trench near the box's walls), the
goals of configs/trenches, a torque margin, a weak wrist and a strong soil (the force constraint
binding) and the objectives: the same feasible sets, d2, curl radii, masks and chosen dig, and the
same volumes, peak torque ratios and cumulative torques (eq. 43) to 1e-9 (on this CPU they agree
bit for bit: the kernel repeats the reference's floating-point operations).
"""

from __future__ import annotations

import numpy as np
import pytest

from excavsim import constants
from excavsim.config import get_soil, load_planner_config, load_trench_goal
from excavsim.handoff.goal import goal_profile
from excavsim.handoff.maps import ElevationMap
from excavsim.planning import kernel
from excavsim.planning.predictor import WedgePredictor
from excavsim.planning.search import TrenchPlanner

WIDTH, CAPACITY = 0.3, 0.0203981  # models/t3/t3.xml numerics
LIMITS = np.array([25000.0, 12000.0, 1000.0])
WEAK = np.array([25000.0, 12000.0, 500.0])


def goal_of(name: str):
    return load_trench_goal(constants.TRENCHES_DIR / f"{name}.yaml")


def planner_for(arm, table, goal: str, *, soil="testbed_sand", limits=LIMITS, **cfg) -> TrenchPlanner:
    s = get_soil(soil)
    config = load_planner_config().model_copy(update=cfg)
    predictor = WedgePredictor(s, WIDTH, capacity_m3=config.heaped_capacity_factor * CAPACITY)
    return TrenchPlanner(arm, table, limits, WIDTH, CAPACITY, goal_of(goal), config, predictor, s.density_kg_m3)


def make_map(kind: str, goal: str, seed: int = 0) -> ElevationMap:
    """The maps of the comparison: the arm plane is the world's x axis (waist 0, axis at the origin)."""
    x0, nx = 0.55, 60
    if kind == "far_wall":
        nx = 48  # the box ends at 2.95 m, 5-15 cm beyond the trenches' far ends
    if kind == "near_wall":
        x0, nx = 1.6, 39  # the box begins at 1.6 m, at or 10 cm short of the trenches' near ends
    cell = 0.05
    xc = x0 + (np.arange(nx) + 0.5) * cell
    z = np.full((60, nx), 0.5)
    if kind == "dug":  # half the trench dug, its far half deeper
        g = goal_profile(goal_of(goal), xc)
        z = z - (0.5 - g)[None, :] * np.where(xc > np.median(xc[g < 0.5]), 0.7, 0.4)[None, :]
    if kind == "bumps":
        rng = np.random.default_rng(seed)
        yc = -1.5 + (np.arange(60) + 0.5) * cell
        for cx, cy, h in zip(rng.uniform(1.5, 3.0, 4), rng.uniform(-0.3, 0.3, 4), rng.uniform(-0.08, 0.08, 4)):
            z = z + h * np.exp(-((xc[None, :] - cx) ** 2 + (yc[:, None] - cy) ** 2) / 0.05)
        z = z + rng.normal(0.0, 0.01, z.shape)
    return ElevationMap(x0, -1.5, cell, z, np.ones(z.shape, bool), 0.0)


# (goal, map, planner options, torque margin)
CASES = {
    "straight-flat": ("straight", "flat", {}, 1.0),
    "sand-flat": ("sand", "flat", {}, 1.0),
    "small-flat": ("small", "flat", {}, 1.0),
    "sand-dug": ("sand", "dug", {}, 1.0),
    "straight-dug-weak-margin": ("straight", "dug", {"limits": WEAK}, 1.5),
    "sand-bumps": ("sand", "bumps", {}, 1.0),
    "straight-bumps-weak-no-volume": ("straight", "bumps", {"limits": WEAK, "volume_constraint": False}, 1.0),
    "sand-far-wall": ("sand", "far_wall", {}, 1.0),
    "straight-far-wall-weak": ("straight", "far_wall", {"limits": WEAK}, 1.0),
    "sand-near-wall": ("sand", "near_wall", {}, 1.0),
    "straight-near-wall-margin": ("straight", "near_wall", {}, 1.5),
    "small-clay-weak-margin": ("small", "flat", {"soil": "lean_clay", "limits": WEAK}, 1.3),
    "sand-flat-weak-no-volume-cumulative": ("sand", "flat", {"limits": WEAK, "volume_constraint": False,
                                                             "objective": "cumulative_torque"}, 1.0),
    "straight-bumps-peak": ("straight", "bumps", {"objective": "peak_torque"}, 1.2),
}


def assert_same_plan(fast, ref):
    np.testing.assert_array_equal(fast.feasible, ref.feasible)
    feas = ref.feasible
    np.testing.assert_array_equal(fast.d2[feas], ref.d2[feas])
    np.testing.assert_array_equal(fast.curl_radius[feas], ref.curl_radius[feas])
    for key in ("volume", "peak_torque_ratio", "cumulative_torque"):
        a, b = getattr(fast, key), getattr(ref, key)
        np.testing.assert_array_equal(np.isnan(a), np.isnan(b), err_msg=key)
        np.testing.assert_allclose(a[feas], b[feas], rtol=1e-9, atol=0.0, err_msg=key)
    for name, mask in ref.masks.items():
        np.testing.assert_array_equal(fast.masks[name], mask, err_msg=name)
    np.testing.assert_array_equal(fast.limiting, ref.limiting)
    assert fast.action == ref.action and fast.reason == ref.reason
    assert fast.utility == pytest.approx(ref.utility, rel=1e-9)
    assert fast.volume_m3 == pytest.approx(ref.volume_m3, rel=1e-9)
    np.testing.assert_array_equal(fast.poses, ref.poses)
    assert fast.counts["pruned_d1"] == ref.counts["pruned_d1"] and fast.counts["evaluated"] == ref.counts["evaluated"]


@pytest.mark.parametrize("case", list(CASES))
def test_the_kernel_plans_what_the_reference_plans_cell_by_cell(arm, reach_table, case):
    goal, kind, options, margin = CASES[case]
    planner = planner_for(arm, reach_table, goal, **options)
    assert planner.uses_kernel()
    emap = make_map(kind, goal)
    fast = planner.plan(emap, torque_margin=margin)
    ref = planner.plan(emap, torque_margin=margin, kernel=False)
    assert ref.feasible.any() and ref.action is not None  # a comparison with something in it
    assert_same_plan(fast, ref)


def test_the_comparison_covers_binding_force_walls_and_the_curl_search(arm, reach_table):
    """What the cases above are for: the force constraint and the box's walls change the feasible sets
    and d2, and d2 is found by the refinement between strides as well as on them."""
    planner = planner_for(arm, reach_table, "straight", limits=WEAK, volume_constraint=False)
    emap = make_map("bumps", "straight")
    weak = planner.plan(emap, torque_margin=1.0)
    planner.limits = np.full(3, np.inf)
    free = planner.plan(emap)
    assert free.feasible.sum() > weak.feasible.sum() > 0
    assert (free.d2[weak.feasible] > weak.d2[weak.feasible]).sum() > 20  # force cuts d2 short
    base = planner_for(arm, reach_table, "sand").plan(make_map("flat", "sand"))
    for kind, goal in (("far_wall", "straight"), ("near_wall", "sand")):
        walled = planner_for(arm, reach_table, goal).plan(make_map(kind, goal))
        flat = planner_for(arm, reach_table, goal).plan(make_map("flat", goal))
        assert walled.masks["sensible"].sum() < flat.masks["sensible"].sum()
        assert walled.feasible.sum() < flat.feasible.sum()
    assert len(np.unique(np.rint(base.d2[base.feasible] / 0.025) % 4)) == 4  # every residue of the stride


def test_the_reference_is_used_where_the_kernel_does_not_apply(arm, reach_table):
    planner = planner_for(arm, reach_table, "small")
    assert planner.uses_kernel() and not planner.uses_kernel(prune=False)
    assert not planner.uses_kernel(classify_limits=True) and not planner.uses_kernel(kernel=False)

    class Learned:  # a predictor without the wedge's numbers (a learned one is Python)
        def __init__(self, inner):
            self.inner = inner

        def predict(self, depth, rake, volume, context=None):
            return self.inner.predict(depth, rake, volume, context)

    emap = make_map("flat", "small")
    fast = planner.plan(emap)
    planner.predictor = Learned(planner.predictor)
    assert not planner.uses_kernel()
    assert_same_plan(fast, planner.plan(emap))
    planner.predictor = planner.predictor.inner
    planner.kernel = False
    assert not planner.uses_kernel()


def test_cells_asked_for_in_any_order_are_judged_as_in_the_grid(arm, reach_table):
    """The entry point of annealing: any cells, in any order, repeats allowed."""
    planner = planner_for(arm, reach_table, "sand", limits=WEAK)
    surface = planner.surface(make_map("dug", "sand"))
    feas = planner.feasibility(surface, planner.cfg.volume_limit_m3(CAPACITY), limits=WEAK / 1.2)
    grid = kernel.evaluate_grid(feas, planner.grid_k, planner.grid_alpha, planner.grid_d1)
    cells = np.random.default_rng(3).choice(np.nonzero(grid.alive)[0], 300)
    some = kernel.evaluate_cells(feas, planner.grid_k, planner.grid_alpha, planner.grid_d1, cells)
    assert (some.j >= 0).any()
    np.testing.assert_array_equal(some.j, grid.j[cells])
    for key in ("radius", "volume", "peak", "cum"):
        np.testing.assert_array_equal(getattr(some, key), getattr(grid, key)[cells], err_msg=key)
    for name in grid.masks:
        np.testing.assert_array_equal(some.masks[name], grid.masks[name][cells], err_msg=name)


def test_the_kernel_matches_the_reference_evaluation_directly(arm, reach_table):
    """Feasibility.evaluate on the lines' verdicts (the reference plan uses) against the kernel, with its radii."""
    planner = planner_for(arm, reach_table, "straight", limits=WEAK)
    surface = planner.surface(make_map("bumps", "straight", seed=5))
    feas = planner.feasibility(surface, planner.cfg.volume_limit_m3(CAPACITY))
    out = kernel.evaluate_grid(feas, planner.grid_k, planner.grid_alpha, planner.grid_d1)
    k, alpha, d1 = planner.grid_cells()
    idx = np.nonzero(out.alive)[0]
    pen = planner.penetrate(k, alpha, d1, surface)
    lines = feas.penetration_lines(planner.grid_k, planner.grid_alpha, planner.grid_d1, k, alpha, d1)
    ref = feas.evaluate(pen[idx], planner.drag(pen[idx, -1]), True, lines.take(idx))
    np.testing.assert_array_equal(out.j[idx], ref.j)
    np.testing.assert_array_equal(out.radius[idx], ref.radius)
    ok = ref.j >= 0
    assert ok.sum() > 100 and len(np.unique(ref.radius[ok])) > 1  # more than the smallest radius occurs
    for key in ("volume", "peak", "cum"):
        np.testing.assert_allclose(getattr(out, key)[idx][ok], getattr(ref, key)[ok], rtol=1e-9, err_msg=key)


def test_annealing_with_the_kernel_chooses_what_it_chose_with_the_reference(arm, reach_table):
    from excavsim.planning.anneal import anneal

    planner = planner_for(arm, reach_table, "sand", limits=WEAK)
    emap = make_map("dug", "sand")
    fast = anneal(planner, emap, seed=2)
    planner.kernel = False
    ref = anneal(planner, emap, seed=2)
    assert fast.action is not None and fast.action == ref.action and fast.cell == ref.cell
    np.testing.assert_array_equal(fast.evaluated, ref.evaluated)
    for key in ("volume_m3", "peak_torque_ratio", "cumulative_torque", "curl_radius_m"):
        assert getattr(fast, key) == pytest.approx(getattr(ref, key), rel=1e-9), key
    planner.kernel = True
    exhaustive = planner.plan(emap)  # the kernel's cells are the plan's, bit for bit
    c = fast.cell
    assert fast.volume_m3 == exhaustive.volume[c] and fast.peak_torque_ratio == exhaustive.peak_torque_ratio[c]
