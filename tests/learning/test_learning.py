"""Learning to predict resistive forces (Singh 1995 §5.2): bases, methods, evaluation, online use.

Most tests run on ``tests/data/learning_digs.npz``, force samples of 12 simulated digs
(regenerate with ``python tests/data/make_learning_digs.py``); one runs a short episode.
"""

from __future__ import annotations

import math
import pathlib

import numpy as np
import pytest

from excavsim import constants
from excavsim.config import get_soil, load_planner_config, load_trench_goal
from excavsim.errors import ExcavsimError
from excavsim.handoff.forces import DigContext, trajectory_progress
from excavsim.handoff.goal import SurfaceProfile
from excavsim.handoff.maps import ElevationMap
from excavsim.learning.adapter import LearnedForcePredictor
from excavsim.learning.bases import MECHANICS, NAIVE, REDUCED, Basis
from excavsim.learning.dataset import ForceDataset, path_progress
from excavsim.learning.encoding import Terrain
from excavsim.learning.evaluate import cross_validate, magnitude
from excavsim.learning.predictors import (METHODS, GlobalRegression, LocallyWeightedRegression, NearestNeighbours,
                                          NeuralNet, WedgeModel, make_model)
from excavsim.mechanics.wedge import G_M_S2, tip_to_plane
from excavsim.planning.predictor import WedgePredictor
from excavsim.planning.search import TrenchPlanner

DATA = constants.REPO_ROOT / "tests" / "data" / "learning_digs.npz"  # the shared data folder, not this test's
SAND = get_soil("testbed_sand")
WIDTH, CAPACITY = 0.3, 0.0203981  # models/t3/t3.xml numerics
LIMITS = np.array([25000.0, 12000.0, 1000.0])


@pytest.fixture(scope="module")
def digs() -> ForceDataset:
    return ForceDataset.load(DATA)


def _eq18(x: np.ndarray) -> np.ndarray:
    return 3.0 * np.sin(x) + 4.0 * np.cos(0.2 * x) + (0.02 * x) ** 2


def _columns(x: np.ndarray) -> dict[str, np.ndarray]:
    return {"x": x, "sinx": np.sin(x), "cosx": np.cos(x), "cos02x": np.cos(0.2 * x)}


LINE = Basis("line", "20", (("x", 1),), ("x",))
APPROX = Basis("approximate", "21", (("sinx", 1), ("cosx", 1), ("x", 2)), ("sin x", "cos x", "x^2"))
EXACT = Basis("exact", "18", (("sinx", 1), ("cos02x", 1), ("x", 2)), ("sin x", "cos 0.2x", "x^2"))


def test_the_bases_are_equations_15_to_17(digs):
    assert (NAIVE.size, MECHANICS.size, REDUCED.size) == (11, 12, 8)
    assert MECHANICS.labels == ("rho", "d_1", "d_2", "l_1^2", "l_2^2", "l_3^2", "l_4^2", "l_5^2", "c_1^2", "c_2^2",
                                "c_3^2", "v")
    assert REDUCED.labels == ("rho", "d_1", "d_2", "l_1^2", "l_2^2", "l_3^2", "c_2^2", "v")
    s = digs.samples
    g = MECHANICS.design(s)
    np.testing.assert_array_equal(g[:, 0], s["rake"])
    np.testing.assert_array_equal(g[:, 3], s["l1"] ** 2)
    np.testing.assert_array_equal(g[:, -1], s["v"])
    np.testing.assert_array_equal(NAIVE.design(s)[:, :3], np.stack([s["alpha"], s["s1"], s["s2"]], axis=-1))
    # for one dig, alpha and the naive l_i are fixed while d_1, d_2 and c_j vary with the bucket (§5.2.2)
    one = digs.subset(digs["dig"] == 3)
    assert np.ptp(one["alpha"]) == 0 and np.ptp(one["lz2"]) == 0
    assert np.ptp(one["s1"]) > 0.1 and np.ptp(one["cz2"]) > 0


def test_the_generic_methods_recover_the_1d_example_from_noisy_data_with_a_gap():
    """Eq. 18 plus unit Gaussian noise, with the data in x in (4, 6) removed (Fig. 68)."""
    rng = np.random.default_rng(18)
    x = rng.uniform(0.0, 20.0, 400)
    x = x[(x < 4.0) | (x > 6.0)]
    y = _eq18(x) + rng.normal(0.0, 1.0, x.size)
    targets = np.stack([y, -2.0 * y], axis=-1)  # two outputs, as F_x and F_z
    xq = np.linspace(0.0, 20.0, 401)
    truth = _eq18(xq)

    def error(model) -> np.ndarray:
        """|prediction - truth| of both outputs (the second scaled back), the larger per point."""
        pred = model.fit(_columns(x), targets).predict(_columns(xq))
        return np.maximum(np.abs(pred[:, 0] - truth), np.abs(pred[:, 1] / -2.0 - truth))

    # global regression (Fig. 69): the exact basis recovers the function's weights, also in the gap
    exact = GlobalRegression(EXACT)
    assert error(exact).max() < 0.4
    np.testing.assert_allclose(exact.weights()[:2, 0], [3.0, 4.0], atol=0.2)
    line, approx = error(GlobalRegression(LINE)).mean(), error(GlobalRegression(APPROX)).mean()
    assert approx < 0.8 * line
    # memory-based methods and the net on x alone (Figs. 70, 72) average the noise (std 1) away;
    # the net sees the data 2000 times, with a weak penalty (the thesis' Fig. 72: 5000 times)
    for model in (NearestNeighbours(LINE), LocallyWeightedRegression(LINE),
                  NeuralNet(LINE, alpha=1e-4, max_iter=2000, seed=0)):
        err = error(model)
        assert err.mean() < 0.7 < line, model.name
        assert err.max() < 2.5, model.name


def test_recursive_least_squares_converges_to_the_batch_solution(rng):
    """Eq. 22 sample by sample from a vague prior ends where eq. 19 solves in one go."""
    x = rng.normal(size=(500, 4)) * [1.0, 10.0, 0.1, 3.0]
    y = x @ rng.normal(size=(4, 2)) + [5.0, -2.0] + rng.normal(0.0, 0.5, (500, 2))
    basis = Basis("four", "-", tuple((f"x{i}", 1) for i in range(4)), tuple(f"x{i}" for i in range(4)))
    cols = {f"x{i}": x[:, i] for i in range(4)}
    batch = GlobalRegression(basis).fit(cols, y)
    rls = GlobalRegression(basis, recursive=True, prior_scale=1e8).fit(cols, y)
    np.testing.assert_allclose(rls.weights(), batch.weights(), rtol=1e-5, atol=1e-6)
    # the estimate approaches the batch one as samples arrive
    half = {k: v[:250] for k, v in cols.items()}
    early = GlobalRegression(basis, recursive=True, prior_scale=1e8).fit(half, y[:250])
    assert np.abs(early.weights() - batch.weights()).max() > np.abs(rls.weights() - batch.weights()).max()
    # updating a batch fit with new samples gives the batch fit of all of them
    rest = {k: v[250:] for k, v in cols.items()}
    continued = GlobalRegression(basis).fit(half, y[:250]).update(rest, y[250:])
    np.testing.assert_allclose(continued.weights(), batch.weights(), rtol=1e-6, atol=1e-8)


def test_on_simulated_digs_the_mechanics_basis_beats_the_naive_basis(digs):
    res = cross_validate(digs, soil=SAND, width=WIDTH, methods=["global"], bases=["naive", "mechanics"], folds=10)
    mae = {(r.method, r.basis): r.mae for r in res}
    assert mae["global", "mechanics"] < 0.75 * mae["global", "naive"]
    # and learning beats the wedge model, nominal and fitted (§5.2.4.2)
    assert mae["global", "mechanics"] < mae["wedge_fit", None] < mae["wedge_nominal", None]


def test_table4_puts_whole_digs_first_and_the_shuffled_protocol_beside_it(digs):
    """Held-out digs is the planner's situation (the primary figure); shuffled samples flatter the
    memory-based methods, whose neighbouring samples of one dig are near-duplicates."""
    from excavsim.learning.evaluate import format_table4

    kw = dict(soil=SAND, width=WIDTH, methods=["nn3"], bases=["mechanics"], folds=5)
    held = cross_validate(digs, by_dig=True, **kw)
    shuffled = cross_validate(digs, by_dig=False, **kw)
    nn = {r.method: r.mae for r in held}["nn3"], {r.method: r.mae for r in shuffled}["nn3"]
    assert nn[1] < 0.7 * nn[0]  # shuffling flatters nearest neighbours
    text = format_table4(held, digs, folds=5, beside=shuffled)
    assert f"{nn[0]:.1f} ({nn[1]:5.1f})" in text


def test_predictions_are_vectorized_and_finite_outside_the_training_range(digs):
    train = digs.subset(digs["dig"] < 10)
    rng = np.random.default_rng(1)
    pick = rng.integers(0, len(digs), (3, 4, 5))
    grid = {c: v[pick] for c, v in digs.samples.items()}  # (3, 4, 5) candidate samples
    far = {c: np.where(rng.random(v.shape) < 0.5, -50.0, 80.0) * (1.0 + np.abs(v)) for c, v in grid.items()}
    models = [make_model(m, "mechanics") for m in METHODS] + [make_model("lwr", "naive"),
                                                               WedgeModel(SAND, WIDTH, starts=1)]
    for model in models:
        model.fit(train.samples, train.forces)
        out = model.predict(grid)
        assert out.shape == (3, 4, 5, 2), model.name
        flat = model.predict({c: v.reshape(-1) for c, v in grid.items()})
        np.testing.assert_allclose(out.reshape(-1, 2), flat, rtol=1e-9, atol=1e-6, err_msg=model.name)
        assert np.all(np.isfinite(model.predict(far))), model.name
        assert model.nbytes > 0


def test_a_force_data_set_round_trips_through_every_format(digs, tmp_path):
    part = digs.subset(np.arange(50))
    for suffix in (".parquet", ".csv", ".npz"):
        back = ForceDataset.load(part.save(tmp_path / f"forces{suffix}"))
        assert back.meta == part.meta
        for c, v in part.columns.items():
            np.testing.assert_allclose(back[c], v, rtol=1e-8, err_msg=f"{suffix} {c}")


def test_samples_take_the_progress_of_the_nearest_point_of_the_planned_path():
    alpha, eps = math.radians(30.0), math.radians(10.0)
    s = np.linspace(0.0, 0.2, 5)
    pen = np.stack([2.5 - s * math.cos(alpha), 0.5 - s * math.sin(alpha), np.full(5, alpha + eps)], axis=-1)
    drag = np.stack([pen[-1, 0] - np.linspace(0.05, 0.3, 6), np.full(6, pen[-1, 1]), np.full(6, 0.5)], axis=-1)
    path = np.concatenate([pen, drag])
    phases = np.r_[np.zeros(5), np.ones(6)]
    prog = path_progress(np.array([[pen[2, 0], pen[2, 1] - 0.01, alpha + eps],
                                   [drag[2, 0] - 0.025, drag[2, 1] + 0.005, 0.5]]), path, phases, eps)
    np.testing.assert_allclose(prog[:, :2], [[2.5, alpha]] * 2)
    np.testing.assert_allclose(prog[:, 2:], [[0.1 + 0.01 * math.sin(alpha), 0.0], [0.2, 0.175]], atol=1e-9)
    np.testing.assert_allclose(trajectory_progress(path, phases, eps)[-1], [2.5, alpha, 0.2, 0.3], atol=1e-12)


class _Spy:
    """A wedge predictor that keeps every context the planner sends."""

    def __init__(self, inner):
        self.inner, self.contexts = inner, []

    def predict(self, depth, rake, volume, context=None):
        self.contexts.append(context)
        return self.inner.predict(depth, rake, volume, context)


def _flat_map() -> ElevationMap:
    return ElevationMap(0.55, -1.5, 0.05, np.full((60, 60), 0.5), np.ones((60, 60), bool), 0.0)


def _planner(arm, table, predictor) -> TrenchPlanner:
    goal = load_trench_goal(constants.TRENCHES_DIR / "straight.yaml")
    return TrenchPlanner(arm, table, LIMITS, WIDTH, CAPACITY, goal, load_planner_config(), predictor,
                         SAND.density_kg_m3)


def test_the_planner_gives_every_force_query_its_dig_context_and_the_wedge_ignores_it(arm, reach_table):
    plain = _planner(arm, reach_table, WedgePredictor(SAND, WIDTH)).plan(_flat_map())
    spy = _Spy(WedgePredictor(SAND, WIDTH))
    plan = _planner(arm, reach_table, spy).plan(_flat_map())
    assert plan.action == plain.action and np.array_equal(plan.feasible, plain.feasible)
    np.testing.assert_array_equal(plan.forces, plain.forces)
    assert all(c.progress is not None and c.progress.shape == c.poses.shape[:-1] + (4,) for c in spy.contexts)
    assert all(c.surface is not None for c in spy.contexts)
    k, alpha, d1, d2 = plan.action
    final = spy.contexts[-1].progress  # the chosen dig's whole path comes last
    np.testing.assert_allclose(final[-1], [k, alpha, d1, d2], atol=1e-9)
    np.testing.assert_allclose(final[0], [k, alpha, 0.0, 0.0], atol=1e-9)


def test_a_learned_predictor_plans_with_the_soil_force_in_the_arm_plane(arm, reach_table, digs):
    model = GlobalRegression("mechanics").fit(digs.samples, digs.forces)
    learned = LearnedForcePredictor(model, density_kg_m3=SAND.density_kg_m3, epsilon_rad=math.radians(10.0))
    emap = _flat_map()
    learned.bind(Terrain.from_map(emap, arm, 0.0, WIDTH))
    plan = _planner(arm, reach_table, learned).plan(emap)
    assert plan.action is not None and np.all(np.isfinite(plan.forces))
    # the planner's force is the sensor's prediction in the arm plane less the carried load's weight
    ctx_poses = plan.poses
    prog = trajectory_progress(plan.poses, plan.phases, math.radians(10.0))
    vol = np.linspace(0.0, plan.volume_m3, len(ctx_poses))
    got = learned.predict(None, ctx_poses[:, 2], vol, DigContext(ctx_poses, prog, None))
    tip = model.predict(learned.samples(vol, DigContext(ctx_poses, prog, None)))
    fx, fz = tip_to_plane(tip[:, 0], tip[:, 1], ctx_poses[:, 2])
    np.testing.assert_allclose(got, np.stack([fx, fz + SAND.density_kg_m3 * G_M_S2 * vol], axis=-1), rtol=1e-12)
    assert magnitude(got).max() > 100.0
    # a path without progress (a boundary-following dig) is read off its shape: down, along, up
    surface = SurfaceProfile.from_map(emap, arm, 0.0, WIDTH)
    guessed = learned.predict(None, ctx_poses[:, 2], vol, DigContext(ctx_poses, None, surface))
    assert guessed.shape == got.shape and np.all(np.isfinite(guessed))
    n = int(np.sum(plan.phases < 2))
    np.testing.assert_allclose(guessed[:n], got[:n], rtol=1e-9)  # penetration and drag recognized exactly


def test_the_online_observer_updates_the_predictor_after_every_dig():
    from excavsim.rig.online import OnlineLearning
    from excavsim.loop.scenario import EpisodeSpec, run_spec

    spec = EpisodeSpec(goal="straight", seed=0, dig_budget=2,
                       sensing={"map": {"n_scans": 2}, "scanner": {"n_azimuth": 100, "n_elevation": 100}})
    observer = OnlineLearning("global", min_digs=1)
    res = run_spec(spec, observer=observer)
    assert len(res.digs) == 2 and [h.index for h in observer.history] == [1, 2]
    assert observer.data.n_digs == 2 and len(observer.data) == sum(h.samples for h in observer.history) > 50
    assert observer.model.fitted and observer.predictor.active
    assert observer.rig.planner.predictor is observer.predictor
    # the first dig was planned with the nominal model, the second with the one learned from the first
    assert math.isnan(observer.history[0].learned_mae) and np.isfinite(observer.history[1].learned_mae)
    assert np.isfinite(observer.history[1].nominal_mae)
    # the peak ratios: the first dig's against the nominal model (it planned it), the second's
    # against the learned one; the peak margin is the answering model's, clipped to [1, peak_max]
    p = observer.predictor
    assert len(p.nominal_peak_ratios) == 1 and len(p.peak_ratios) == 1
    assert p.peak_margin == pytest.approx(min(max(p.peak_ratios[0], 1.0), p.peak_max))
    with p.nominal_answers():
        assert not p.active
        assert p.peak_margin == pytest.approx(min(max(p.nominal_peak_ratios[0], 1.0), p.peak_max))
    assert p.active


class _Boulders(GlobalRegression):
    """A learned model gone wrong: it predicts 100 kN everywhere (every dig over the torque limits)."""

    def predict(self, samples):
        return np.full(np.shape(samples["v"]) + (2,), 1e5)


class _Scaled(GlobalRegression):
    """A learned model that predicts the nominal wedge's tip forces times ``scale``: a much harder soil."""

    def __init__(self, wedge, scale: float):
        super().__init__("mechanics")
        self.wedge, self.scale = wedge, float(scale)
        self.k = np.zeros(1)  # "fitted"

    def predict(self, samples):
        return self.scale * self.wedge.predict(samples)


def test_a_learned_model_that_forbids_every_dig_within_the_limits_plans_the_one_least_over_them():
    from excavsim.learning.predictors import WedgeModel
    from excavsim.tasks.trench.digs import OVER_LIMIT_MARGINS, PlannedDigs
    from excavsim.rig.core import make_rig
    from excavsim.world.simulation import Simulation

    rig = make_rig(Simulation(seed=0))
    emap = _flat_map()
    nominal = rig.planner.predictor
    # 75 x the wedge's forces on the flat map: nothing within the limits, nor within 1.1 x them
    learned = LearnedForcePredictor(_Scaled(WedgeModel(SAND, rig.width, fit_params=False), 75.0),
                                    density_kg_m3=SAND.density_kg_m3, epsilon_rad=math.radians(10.0), nominal=nominal)
    learned.bind(Terrain.from_map(emap, rig.arm, 0.0, rig.width))
    rig.planner.predictor = learned
    assert rig.planner.plan(emap).action is None
    assert rig.planner.plan(emap, torque_margin=OVER_LIMIT_MARGINS[0]).action is None
    within = rig.planner.plan(emap, torque_margin=OVER_LIMIT_MARGINS[1])
    assert within.action is not None
    choice = PlannedDigs().choose(rig, emap)
    assert choice.dig is not None and choice.dig.kind == "planned" and choice.dig.action == within.action
    assert "predicts least over them" in choice.note and "x 1.25" in choice.note
    # the learned model answered (not the nominal one), and its torques run over the limits, by at most 1.25
    ratio = np.abs(within.torques).max(axis=0) / rig.planner.limits
    assert 1.0 < ratio.max() <= 1.25 + 1e-9
    with pytest.raises(ExcavsimError, match="torque_margin"):
        rig.planner.plan(emap, torque_margin=0.0)


def test_the_peak_margin_counts_a_stalled_digs_ratio_as_a_lower_bound():
    from excavsim.learning.adapter import censored_quantile

    rng = np.random.default_rng(3)
    x = rng.lognormal(0.1, 0.3, 41)
    for q in (0.2, 0.5, 0.8):  # without censoring: the empirical quantile
        assert censored_quantile(x, np.zeros(41, bool), q) == np.quantile(x, q, method="inverted_cdf")
    # by hand: 1, 2 (censored), 3, 4: S = 3/4 after 1, 3/4 * 1/2 after 3 (2 values at risk), 0 after 4
    v, c = np.array([1.0, 2.0, 3.0, 4.0]), np.array([False, True, False, False])
    assert censored_quantile(v, c, 0.25) == 1.0 and censored_quantile(v, c, 0.5) == 3.0
    assert censored_quantile(v, c, 0.62) == 3.0 and censored_quantile(v, c, 0.63) == 4.0
    assert censored_quantile(np.array([1.0, 2.0]), np.array([False, True]), 0.8) == math.inf
    with pytest.raises(ExcavsimError):
        censored_quantile(v, c[:3], 0.5)
    # the predictor: a completed dig at 1.1 and a stall at 1.3 bound the 0.8 quantile from below only
    p = LearnedForcePredictor(GlobalRegression("mechanics"), density_kg_m3=SAND.density_kg_m3,
                              epsilon_rad=math.radians(10.0), nominal=WedgePredictor(SAND, WIDTH))
    p.add_peak_ratio(1.1)
    assert p.peak_margin == pytest.approx(1.1)
    p.add_peak_ratio(1.3, stalled=True)
    assert p.nominal_peak_censored == [False, True] and p.peak_ratios == []  # not fitted: the nominal's ratios
    assert p.peak_margin == p.peak_max  # counted as exact it would be 1.26, below the stall
    p.add_peak_ratio(1.5)
    p.add_peak_ratio(1.2)
    assert p.peak_margin == pytest.approx(1.5)


def test_a_learned_model_that_forbids_every_dig_hands_the_choice_to_the_nominal_model():
    from excavsim.tasks.trench.digs import PlannedDigs
    from excavsim.rig.core import make_rig
    from excavsim.world.simulation import Simulation

    rig = make_rig(Simulation(seed=0))
    emap = _flat_map()
    nominal = rig.planner.predictor
    learned = LearnedForcePredictor(_Boulders("mechanics"), density_kg_m3=SAND.density_kg_m3,
                                    epsilon_rad=math.radians(10.0), nominal=nominal)
    learned.model.k = np.zeros(1)  # "fitted": the adapter asks it, and its predictions are the boulders
    learned.peak_ratios[:] = [3.0]  # and it learned that peaks run far above its predictions
    assert learned.peak_margin == learned.peak_max
    learned.bind(Terrain.from_map(emap, rig.arm, 0.0, rig.width))
    rig.planner.predictor = learned
    assert rig.planner.plan(emap).action is None  # the learned model alone leaves no dig
    choice = PlannedDigs().choose(rig, emap)
    assert choice.dig is not None and choice.dig.kind == "planned"
    assert "the learned force model leaves no dig" in choice.note and "nominal model planned" in choice.note
    rig.planner.predictor = nominal
    assert choice.dig.action == rig.planner.plan(emap).action  # what the nominal model plans alone
    assert learned.active  # answering nominally was for that choice only
