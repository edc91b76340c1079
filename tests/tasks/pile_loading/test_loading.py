"""Loading from a pile (Singh 1995 §3.5, §4.1-4.2, §7.2.1, App. A1-2): machines, action, world, study."""

from __future__ import annotations

import math

import numpy as np
import pytest

from excavsim.errors import ExcavsimError
from excavsim.robot.loaders import FrontLoader, dh_transform
from excavsim.tasks.pile_loading import planar as L
from excavsim.tasks.pile_loading.mind import planner as lp
from excavsim.tasks.pile_loading.world.pile2d import Pile2D, random_pile, trapezoid_pile


@pytest.fixture(scope="module")
def cfg():
    return L.load_loading_config()


@pytest.fixture(scope="module")
def machines(cfg):
    return {m: L.make_machine(cfg, m) for m in L.MACHINES}


def _random_q(machine, n, seed=0):
    rng = np.random.default_rng(seed)
    return machine.lower + rng.random((n, 3)) * (machine.upper - machine.lower)


def test_loader_forward_kinematics_is_table_a1_3(machines):
    loader = machines["loader"]
    for q in _random_q(loader, 20):
        t = loader.forward_dh(q)  # (A1 21) times Table A1-3's four rows
        pose = loader.forward(q)
        assert np.allclose(t[:2, 3], pose[:2], atol=1e-12)  # the thesis' y_w is our z
        assert abs(t[2, 3]) < 1e-12  # planar
        assert np.allclose(t[:2, 0], [math.cos(pose[2]), math.sin(pose[2])], atol=1e-12)  # the tip frame's x_4


def test_table_rows_are_the_printed_transforms_with_l1_and_theta2_turned(machines):
    """(A1 20)'s 1_2T uses theta2 and a_1 = +l1; the table pi + theta2 and -l1: the same chain, l1 -> -l1."""
    loader = machines["loader"]
    q = np.array([0.7, 1.1, 0.4])
    table = dh_transform(math.pi / 2, -loader.l1, math.pi + q[1], 0.0)
    printed = dh_transform(math.pi / 2, loader.l1, q[1], 0.0)
    flipped = dh_transform(math.pi / 2, -loader.l1, q[1] + math.pi, 0.0)
    assert np.allclose(table, flipped)
    assert not np.allclose(table, printed)
    # (A1 22)'s x row with l1 -> -l1, theta2 -> theta2 + pi is our forward kinematics
    t2, t23 = q[1] + math.pi, q[1] + q[2] + math.pi
    x_a1_22 = -loader.l4 * math.sin(t23) - loader.l3 * math.sin(t2) + loader.l2 - q[0]
    assert math.isclose(x_a1_22, loader.forward(q)[0], abs_tol=1e-12)


@pytest.mark.parametrize("name", L.MACHINES)
def test_inverse_kinematics_round_trip(machines, name):
    m = machines[name]
    q = _random_q(m, 200, seed=1)
    poses = m.forward(q) if m.moves_base else m.forward(q, 1.5)
    back, ok = m.inverse(poses) if m.moves_base else m.inverse(poses, 1.5)
    assert ok.mean() > 0.5  # the other solution branch may be the one within limits for some
    again = m.forward(back[ok]) if m.moves_base else m.forward(back[ok], 1.5)
    assert np.allclose(again, poses[ok], atol=1e-9)


@pytest.fixture(scope="module")
def plans(cfg, machines):
    out = {}
    for name in L.MACHINES:
        spec = getattr(cfg.machines, name)
        out[name] = lp.plan(machines[name], L.terrain_of(L.make_pile(cfg)), L.make_rules(cfg, spec.capacity_units))
    return out


@pytest.mark.parametrize("name", L.MACHINES)
def test_planned_dig_is_shaped_and_reachable_by_the_machines_ik(cfg, machines, plans, name):
    m, p = machines[name], plans[name]
    rules = L.make_rules(cfg, getattr(cfg.machines, name).capacity_units)
    terrain = L.terrain_of(L.make_pile(cfg))
    assert p.action is not None
    poses, phase = lp.action_poses(p.action, terrain, rules, m.floor)
    px, pz = lp.path_points(p.action, rules.exit_heading, terrain.xs)
    assert pz.min() >= -rules.tolerance  # shaping: never below the ground
    q, ok = m.inverse(poses) if m.moves_base else m.inverse(poses, p.base_x)
    assert ok.all()
    again = m.forward(q) if m.moves_base else m.forward(q, p.base_x)
    assert np.allclose(again, poses, atol=1e-9)
    assert np.all((q >= m.lower - 1e-12) & (q <= m.upper + 1e-12))
    if m.moves_base:  # the wheels never pass the foot left after the dig
        pile = L.make_pile(cfg)
        pile.carve(px, pz)
        foot = lp.PileSection(pile.xs, pile.heights, pile.dx).foot(rules.wheel_clearance)
        assert np.all(m.wheels_x(q) <= foot + 1e-9)
    assert p.volume <= rules.capacity


def test_a_dig_past_the_ground_fails_shaping_and_an_unreachable_one_reachability(cfg, machines):
    rules = L.make_rules(cfg, 48)
    terrain = L.terrain_of(L.make_pile(cfg))
    foot = terrain.foot(rules.ground)
    a = np.radians([30.0])
    xe = np.array([foot + 0.5])
    verdicts, _, _ = lp.evaluate(machines["loader"], terrain, rules, xe, terrain.surface(xe), a, np.array([3.0]),
                                 np.array([0.5]), math.nan)
    assert not verdicts["shaping"][0]
    far = np.array([foot + 9.0])
    verdicts, _, _ = lp.evaluate(machines["shovel"], terrain, rules, far, terrain.surface(far), np.zeros(1),
                                 np.array([0.5]), np.array([0.5]), lp.base_position(machines["shovel"], terrain, 0.05))
    assert not verdicts["reachability"][0]


def test_entries_on_the_ground_in_front_of_the_foot_skim_a_thin_layer(cfg, machines):
    """§4.1's h runs from 0: k < 0 enters on the bare ground; from the foot column's edge (k = 0, h > 0) a
    level path leaves the layer below its entry height."""
    import dataclasses
    rules = L.make_rules(cfg, 48, coarse=True)
    assert rules.k_min < 0 and 0.0 in rules.grid()[0]
    h = np.zeros(140)
    h[20:50] = 0.08  # 8 cm over 3 m from x = 2 m: 24 units
    terrain = lp.PileSection((np.arange(140) + 0.5) * 0.1, h, 0.1)
    p = lp.plan(machines["loader"], terrain, rules)
    assert p.action.k < 0 and p.action.h == 0.0 and p.volume >= 0.9 * 0.24
    q = lp.plan(machines["loader"], terrain, dataclasses.replace(rules, k_min=0.0))
    assert q.volume < 0.6 * 0.24


def test_shovel_base_moves_to_reach_soil_beyond_what_it_drives_over(cfg, machines):
    """§4.2: the shovel's base is placed between digs. A thin layer (under the tracks' clearance) from 1 m
    to 6 m, then a heap: from the thin layer's foot nothing of the heap is in reach; the planner drives the
    tracks up to the heap (never onto soil above the clearance) and digs a full bucket."""
    rules = L.make_rules(cfg, 27, coarse=True)
    shovel = machines["shovel"]
    pile = trapezoid_pile(1.5, 0.5, 6.0, 14.0, 0.1, 35.0)
    pile.heights[(pile.xs > 1.0) & (pile.xs < 6.0)] = 0.1
    terrain = L.terrain_of(pile)
    cands = lp.base_candidates(shovel, terrain, rules)
    assert len(cands) == len(rules.base_backoffs)
    for base_x, foot in cands:
        under = (terrain.xs > base_x - 0.05) & (terrain.xs < base_x + shovel.track_front)
        assert terrain.heights[under].max() <= rules.wheel_clearance
        assert foot >= base_x + shovel.track_front - 1e-9
    first = terrain.foot(rules.ground)
    old = lp._plan_at(shovel, terrain, rules, first, first - shovel.track_front)
    assert old.volume < 0.5 * rules.capacity  # the old placement, tracks at the first soil, reaches little
    p = lp.plan(shovel, terrain, rules)
    assert p.base_x > 4.0 - shovel.track_front and p.volume > 0.9 * rules.capacity
    q, ok = shovel.inverse(lp.action_poses(p.action, terrain, rules, shovel.floor)[0], p.base_x)
    assert ok.all()


@pytest.mark.parametrize("name", L.MACHINES)
def test_planned_volume_is_the_area_the_world_removes(cfg, machines, plans, name):
    p = plans[name]
    pile = L.make_pile(cfg)
    before = pile.area()
    rules = L.make_rules(cfg, 48)
    removed = pile.carve(*lp.path_points(p.action, rules.exit_heading, pile.xs))
    assert removed == pytest.approx(p.volume, rel=1e-12, abs=1e-12)
    assert before - pile.area() == pytest.approx(removed, abs=1e-12)
    pile.settle()
    assert pile.area() == pytest.approx(before - removed, abs=1e-9)  # settlement conserves soil
    slope = np.abs(np.diff(pile.heights)) / pile.dx
    assert slope.max() <= math.tan(math.radians(pile.repose_deg)) + 1e-6


def test_parameterizations_k_alpha_and_k_alpha_r(cfg, machines):
    terrain = L.terrain_of(L.make_pile(cfg))
    base = L.make_rules(cfg, 27, coarse=True)
    import dataclasses
    three = dataclasses.replace(base, parameterization="k_alpha_r")
    p2, p3 = lp.plan(machines["shovel"], terrain, base), lp.plan(machines["shovel"], terrain, three)
    assert p2.d1.shape[-1] == 1 and p3.d1.shape[-1] == len(base.radii)
    assert p2.action.r in base.radii and p3.action.r in base.radii
    assert np.isfinite(p3.d1).sum() >= np.isfinite(p2.d1).sum()  # more digs to choose from


@pytest.fixture(scope="module")
def loader_run(cfg):
    return L.run_machine(cfg, "loader")


def test_loader_fig108_runs_to_the_end(loader_run):
    run = loader_run
    assert len(run.digs) >= 5
    assert run.end_m2 < 0.1 * run.start_m2
    assert all(d.planned_m2 == pytest.approx(d.removed_m2, abs=1e-12) for d in run.digs)


def test_force_constraint_lowers_the_loaders_efficiency(cfg, loader_run):
    free = loader_run
    held = L.run_machine(cfg, "loader", force=True)
    assert held.efficiency() < free.efficiency()
    assert max(d.force_n_m for d in held.digs) <= 1000 * cfg.fig111_force_limit_kn_m + 1e-6


def test_study_is_deterministic_for_a_seed(cfg):
    short = cfg.model_copy(update={"study": cfg.study.model_copy(update={"remove_units": 300.0})})  # fast
    a = L.study_run(short, "loader", 6.0, seed=3)
    b = L.study_run(short, "loader", 6.0, seed=3)
    assert a == b
    assert a[1] >= 3.0 - 1e-9 and a[2] == "300 units removed"
    p1 = random_pile(3, 10.0, foot=1.0, width=14.0, dx=0.1, repose_deg=35.0)
    p2 = random_pile(3, 10.0, foot=1.0, width=14.0, dx=0.1, repose_deg=35.0)
    p3 = random_pile(4, 10.0, foot=1.0, width=14.0, dx=0.1, repose_deg=35.0)
    assert np.array_equal(p1.heights, p2.heights) and not np.array_equal(p1.heights, p3.heights)
    assert p1.area() == pytest.approx(10.0, rel=1e-6)


def test_bad_inputs_give_clear_errors(cfg):
    with pytest.raises(ExcavsimError, match="parameterization"):
        lp.LoadingRules(parameterization="k_h")
    with pytest.raises(ExcavsimError, match="force_limit"):
        lp.LoadingRules(force_limit=-1.0)
    with pytest.raises(ExcavsimError, match="capacity"):
        lp.LoadingRules(capacity=0.0)
    with pytest.raises(ExcavsimError, match="angle of repose"):
        Pile2D(np.ones(5), 0.1, repose_deg=95.0)
    with pytest.raises(ExcavsimError, match="non-decreasing"):
        Pile2D(np.ones(5), 0.1).carve([0.3, 0.1], [0.0, 0.0])
    with pytest.raises(ExcavsimError, match="does not fit"):
        trapezoid_pile(3.0, 1.0, 1.0, 4.0, 0.1, 35.0)
    with pytest.raises(ExcavsimError, match="unknown machine"):
        L.make_machine(cfg, "dragline")
    with pytest.raises(ExcavsimError, match="joint limits"):
        FrontLoader(-1.6, 0.0, 2.6, 1.0, 0.3, np.array([0.0, 1.0, 0.0]), np.array([0.0, 2.0, 1.0]), 0.9, 0.8)
    with pytest.raises(ExcavsimError, match="terrain"):
        lp.PileSection(np.array([0.0, 0.0]), np.array([1.0, 1.0]), 0.1)
