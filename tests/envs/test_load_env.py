"""excavsim/LoadDig-v0 (excavsim.tasks.pile_loading.envs): loading from a pile one dig per step, the action the
loading planner's. Gymnasium's checker, seeding, the snapping of infeasible actions, the planner as a
policy against the plain loading episode, and the errors for bad specs, seeds and actions.

Every episode is tiny: a 0.6 m pile the loader clears in two digs, one coarse scan per map, and a
planner grid of 20 cm and 10 degrees (a quarter of configs/pile_loading_planar.yaml's cells).
"""

from __future__ import annotations

import copy

import gymnasium as gym
import numpy as np
import pytest
from absl.testing import absltest
from dm_env import test_utils
from gymnasium.utils.env_checker import check_env, data_equivalence

from excavsim.envs import EnvError
from excavsim.envs.render import offscreen_error
from excavsim.tasks.pile_loading.envs import LOAD_DIG_ENV_ID
from excavsim.tasks.pile_loading.envs.core import LOAD_WEIGHTS, PROFILE_X
from excavsim.tasks.pile_loading.envs.dig_env import LoadDigEnv, LoadPlannerPolicy
from excavsim.tasks.pile_loading.envs.dm import DmLoadDig
from excavsim.loop.episode import Episode
from excavsim.loop.scenario import EpisodeSpec, resolve
from excavsim.tasks.pile_loading import planar as ld
from excavsim.tasks.pile_loading.task import LoadTask

TINY = {
    "name": "tiny", "dig_budget": 2, "seed": 0,
    "pile_loading": {"pile": {"height": 0.6, "top": 0.3, "foot": 1.5}, "n_scans": 1,
                "scanner": {"n_azimuth": 80, "n_elevation": 20}},
}
_CFG2D = ld.load_loading_config()
COARSE = _CFG2D.model_copy(update={"planner": _CFG2D.planner.model_copy(
    update={"k_step": 0.2, "alpha_deg": [-30.0, 40.0, 10.0]})})


def tiny(**fields) -> dict:
    return {**copy.deepcopy(TINY), **fields}


def make(spec=None, **kwargs) -> LoadDigEnv:
    """The environment of ``spec`` (default :data:`TINY`) on the coarse planner grid."""
    return LoadDigEnv(tiny() if spec is None else spec, loading_config=COARSE, **kwargs)


def run_env(env, policy, seed):
    """An episode of ``env`` with ``policy(obs, info)``: the list of (obs, reward, terminated, truncated, info)."""
    obs, info = env.reset(seed=seed)
    steps = [(obs, 0.0, False, False, info)]
    while not (steps[-1][2] or steps[-1][3]):
        obs, reward, terminated, truncated, info = env.step(policy(obs, info))
        steps.append((obs, reward, terminated, truncated, info))
    return steps


@pytest.mark.filterwarnings("ignore:.*symmetric and normalized")  # deliberate: the planner's units (normalize_action=True)
def test_gymnasium_check_env_passes_and_the_spaces_are_the_documented_ones():
    env = gym.make(LOAD_DIG_ENV_ID, spec=tiny(), loading_config=COARSE)  # two digs: the checker's step must not truncate
    try:
        # the render check makes frames: only where MuJoCo's offscreen renderer has a GL backend
        check_env(env.unwrapped, skip_render_check=offscreen_error() is not None)
        u = env.unwrapped
        assert u.action_space.shape == (2,) and u.action_space.dtype == np.float32
        np.testing.assert_allclose(u.action_space.low, [-0.4, np.radians(-30)], rtol=1e-6)  # configs/pile_loading_planar.yaml
        np.testing.assert_allclose(u.action_space.high, [4.0, np.radians(40)], rtol=1e-6)
        assert u.core.rules.k_step == 0.2
        assert u.observation_space["sections"].shape == (3, PROFILE_X.size) == (3, 170)
        assert u.observation_space["joints"].shape == (3,)  # the loader's travel, boom, bucket
    finally:
        env.close()


class DmLoadDigTest(test_utils.EnvironmentTestMixin, absltest.TestCase):
    """dm_env's own checks of the loading environment; the sequence reaches LAST (2 digs) and starts again."""

    def make_object_under_test(self):
        return DmLoadDig(tiny(), seed=5, loading_config=COARSE)

    def make_action_sequence(self):
        for _ in range(4):
            yield self.make_action()


def test_a_seed_reproduces_an_episode_exactly_and_rewards_are_the_sum_of_their_terms():
    runs = []
    for _ in range(2):
        env = make()
        rng = np.random.default_rng(5)
        runs.append(run_env(env, lambda obs, info: env.action_space.low + rng.random(2) * (
            env.action_space.high - env.action_space.low), seed=3))
        env.close()
    a, b = runs
    assert len(a) == len(b) == 3
    for (oa, ra, ta, tra, ia), (ob, rb, tb, trb, ib) in zip(a, b):
        assert data_equivalence(oa, ob) and ra == rb and (ta, tra) == (tb, trb)
        assert data_equivalence(ia.get("dig"), ib.get("dig"))
    w = LOAD_WEIGHTS
    for _, reward, _, _, info in a[1:]:
        t = info["reward_terms"]
        assert t["delivered_l"] >= 0.0 and t["spilled_l"] >= 0.0 and t["dig"] == 1
        assert reward == pytest.approx(w["delivered_per_l"] * t["delivered_l"] - w["spilled_per_l"] * t["spilled_l"]
                                       - w["dig"] * t["dig"])
    assert sum(s[4]["reward_terms"]["delivered_l"] for s in a[1:]) > 1.0  # random digs still deliver some soil
    assert a[-1][3] and not a[-1][2]  # the budget of two digs truncates
    assert a[-1][4]["episode"]["digs"] == 2


def test_an_infeasible_action_is_dug_as_the_nearest_feasible_cell_and_a_feasible_one_as_given():
    env = make()
    try:
        env.reset(seed=0)
        plan = env.core._pending.plan
        feasible = np.isfinite(plan.d1[..., 0])
        # far beyond the pile, steeply down: the bucket would cut the ground (shaping, §4.1.1)
        ik, ia = plan.grid_k.size - 1, plan.grid_alpha.size - 1
        assert not feasible[ik, ia]
        obs, reward, term, trunc, info = env.step(np.array([plan.grid_k[ik], plan.grid_alpha[ia]], np.float32))
        assert info["snapped_to_allowed"] and not info["planner_cell"]
        cell = tuple(info["executed_cell"][:2])
        assert feasible[cell]
        nearest = min(((c[0] - ik) ** 2 + (c[1] - ia) ** 2) for c in np.argwhere(feasible))
        assert (cell[0] - ik) ** 2 + (cell[1] - ia) ** 2 == nearest
        dug = info["dig"]
        assert dug["k"] == pytest.approx(plan.grid_k[cell[0]]) and dug["alpha"] == pytest.approx(plan.grid_alpha[cell[1]])
        assert dug["d1"] == pytest.approx(plan.d1[cell][0])  # the cell's longest feasible d1
        assert dug["planned_m3"] > 0 and info["reward_terms"]["delivered_l"] > 0
        # the next cycle: a feasible cell other than the planner's is dug as asked
        plan = env.core._pending.plan
        feasible = np.isfinite(plan.d1[..., 0])
        planner = (int(np.argmin(np.abs(plan.grid_k - plan.action.k))),
                   int(np.argmin(np.abs(plan.grid_alpha - plan.action.alpha))))
        other = next(tuple(c) for c in np.argwhere(feasible) if tuple(c) != planner)
        obs, reward, term, trunc, info = env.step(np.array([plan.grid_k[other[0]] + 0.02,
                                                            plan.grid_alpha[other[1]] - 0.01], np.float32))
        assert not info["snapped_to_allowed"] and not info["planner_cell"]
        assert tuple(info["executed_cell"][:2]) == other
        assert info["dig"]["k"] == pytest.approx(plan.grid_k[other[0]])
    finally:
        env.close()


def test_the_planner_as_a_policy_reproduces_the_plain_loading_episode():
    spec = EpisodeSpec(task="pile_loading", **tiny())
    episode = Episode(LoadTask("loader", cfg=resolve(spec), cfg2d=COARSE), dig_budget=2)
    episode.reset(4)
    plain = episode.run()  # what excavsim trench --spec runs for this spec (on the coarse grid)
    env = make(spec)
    steps = run_env(env, LoadPlannerPolicy(env.action_space), seed=4)
    run = env.result
    env.close()
    assert all(s[4]["planner_cell"] and not s[4]["snapped_to_allowed"] for s in steps[1:])
    assert [d.action for d in run.digs] == [d.action for d in plain.digs]
    assert run.delivered_m3 == plain.delivered_m3 > 0.5  # bit for bit: the same episode
    assert run.end_m3 == plain.end_m3 and run.end == plain.end
    assert sum(s[4]["reward_terms"]["delivered_l"] for s in steps[1:]) == pytest.approx(1000 * plain.delivered_m3)


def test_the_shovel_places_its_base_and_observes_four_joints():
    env = make(tiny(machine="shovel", dig_budget=1))
    try:
        obs, info = env.reset(seed=0)
        assert obs["joints"].shape == (4,) and env.observation_space.contains(obs)
        assert obs["reference"][1] == pytest.approx(env.core._pending.plan.base_x)
        obs, reward, term, trunc, info = env.step(LoadPlannerPolicy(env.action_space)(obs, info))
        assert info["dig"]["base_x"] is not None and info["reward_terms"]["delivered_l"] > 0
        assert trunc and env.observation_space.contains(obs)
    finally:
        env.close()


def test_bad_specs_seeds_actions_and_orders_are_refused_with_clear_errors():
    with pytest.raises(EnvError, match=r"task must be 'pile_loading'.*TrenchDig"):
        LoadDigEnv({"task": "trench"})
    with pytest.raises(EnvError, match=r"invalid spec.*allowed: loader, shovel"):
        LoadDigEnv(tiny(machine="t3"))
    with pytest.raises(EnvError, match=r"unknown loading reward weight 'bonus'; allowed: delivered_per_l"):
        LoadDigEnv(tiny(), weights={"bonus": 1.0})
    with pytest.raises(EnvError, match="loading_config must be a LoadingConfig, a YAML path or None; given dict"):
        LoadDigEnv(tiny(), loading_config={"planner": {}})
    env = make(tiny(dig_budget=1))
    try:
        with pytest.raises(EnvError, match="call reset"):
            env.step(np.zeros(2, np.float32))
        for seed in (-1, 2**32, 1.5, True):
            with pytest.raises(EnvError, match=r"seed must be an integer from 0 to 4294967295"):
                env.reset(seed=seed)
        with pytest.raises(EnvError, match="takes no reset options"):
            env.reset(seed=0, options={"pile": 1})
        env.reset(seed=0)
        with pytest.raises(EnvError, match=r"must have shape \(2,\)"):
            env.step(np.zeros(3))
        with pytest.raises(EnvError, match=r"outside the action space \(allowed: .*-0\.4.* to .*4\."):
            env.step(np.array([5.0, 0.0]))
        with pytest.raises(EnvError, match="must be finite"):
            env.step(np.array([np.nan, 0.0]))
        env.step(np.array([1.0, 0.0]))  # the bad actions dug nothing: the episode still runs
        with pytest.raises(EnvError, match="the episode has ended"):
            env.step(np.array([1.0, 0.0]))
    finally:
        env.close()
