"""The trench's environments (excavsim.tasks.trench.envs, on excavsim.envs): the ecosystem's own checkers (Gymnasium's check_env and async
vector envs, dm_env's EnvironmentTestMixin), seeding, the planner as a policy against
``excavsim trench``, and the rules of the actions and rewards.

Every episode is tiny: the small trench, one coarse scan per map and a coarse planner grid, as
configs/campaigns/tiny.yaml runs them, and a budget of two or three digs.
"""

from __future__ import annotations

import copy
import math
import multiprocessing

import gymnasium as gym
import numpy as np
import pytest
import yaml
from absl.testing import absltest
from dm_env import test_utils
from gymnasium.utils.env_checker import check_env, data_equivalence

import excavsim.envs
from excavsim import cli
from excavsim.envs import EnvError
from excavsim.envs.dig_env import PlannerPolicy
from excavsim.envs.dm import DmJoint
from excavsim.envs.render import offscreen_error
from excavsim.tasks.trench.envs import DIG_ENV_ID, JOINT_ENV_ID
from excavsim.tasks.trench.envs.dm import DmTrenchDig
from excavsim.handoff.episode import format_episode
from excavsim.loop.scenario import EpisodeSpec, dig_rows, episode_summary, run_spec

TINY = {
    "name": "tiny", "goal": "small", "dig_budget": 2, "seed": 0,
    "sensing": {"map": {"n_scans": 1}, "scanner": {"n_azimuth": 60, "n_elevation": 60}},
    "planner": {"grid": {"k_min_m": 1.8, "k_max_m": 2.6, "k_step_m": 0.2, "alpha_step_deg": 15.0, "d1_step_m": 0.04}},
}
JOINT = {"max_time_s": 0.5, "scan_period_s": 0.2}  # 50 control steps, a scan every 20


def tiny(**fields) -> dict:
    return {**copy.deepcopy(TINY), **fields}


def run_env(env, policy, seed):
    """An episode of ``env`` with ``policy(obs, info)``: the list of (obs, reward, terminated, truncated, info)."""
    obs, info = env.reset(seed=seed)
    steps = [(obs, 0.0, False, False, info)]
    while not (steps[-1][2] or steps[-1][3]):
        obs, reward, terminated, truncated, info = env.step(policy(obs, info))
        steps.append((obs, reward, terminated, truncated, info))
    return steps


# -- the ecosystem's checkers -------------------------------------------------------------------
def test_both_are_registered_on_import():
    assert excavsim.envs.register()  # idempotent
    for env_id in (DIG_ENV_ID, JOINT_ENV_ID):
        assert env_id in gym.envs.registration.registry


# TrenchDig's action is the planner grid's (k, alpha, d1) in metres and radians, not [-1, 1], on purpose
@pytest.mark.filterwarnings("ignore:.*symmetric and normalized space")
@pytest.mark.parametrize(("env_id", "kwargs"), [(DIG_ENV_ID, {}), (JOINT_ENV_ID, JOINT)])
def test_gymnasium_check_env_passes(env_id, kwargs):
    env = gym.make(env_id, spec=tiny(), **kwargs)
    try:
        # the render check makes frames: only where MuJoCo's offscreen renderer has a GL backend
        # (tests/test_rl.py checks the frames, and the clear error where there is none)
        check_env(env.unwrapped, skip_render_check=offscreen_error() is not None)
    finally:
        env.close()


def test_async_vector_envs_run_two_copies_of_each():
    # forkserver, not fork: numba's OpenMP threads (the scanner's ray cast) make a child forked from
    # this process abort; the server imports the environments once and forks its children from it
    multiprocessing.set_forkserver_preload(["excavsim.tasks.trench.envs.dig_env", "excavsim.envs.joint_env"])
    for env_id, kwargs, steps in ((DIG_ENV_ID, {}, 1), (JOINT_ENV_ID, JOINT, 5)):
        envs = gym.make_vec(env_id, num_envs=2, vectorization_mode="async", vector_kwargs={"context": "forkserver"},
                            spec=tiny(), **kwargs)
        try:
            obs, info = envs.reset(seed=[3, 4])
            assert obs["elevation" if env_id == DIG_ENV_ID else "q"].shape[0] == 2
            for _ in range(steps):
                obs, reward, terminated, truncated, info = envs.step(envs.action_space.sample())
            assert reward.shape == (2,) and np.all(np.isfinite(reward))
            if env_id == DIG_ENV_ID:  # two seeds, two different worlds
                assert not np.array_equal(obs["elevation"][0], obs["elevation"][1])
        finally:
            envs.close()


class DmDigTest(test_utils.EnvironmentTestMixin, absltest.TestCase):
    """dm_env's own checks of the dig environment; the sequence reaches LAST (2 digs) and starts again."""

    def make_object_under_test(self):
        return DmTrenchDig(tiny(), seed=5)

    def make_action_sequence(self):
        for _ in range(4):
            yield self.make_action()


class DmJointTest(test_utils.EnvironmentTestMixin, absltest.TestCase):
    """dm_env's own checks of the joint environment; its 20 default actions pass two ends of 0.1 s episodes."""

    def make_object_under_test(self):
        return DmJoint(tiny(), seed=5, max_time_s=0.1, scan_period_s=0.05)


def test_dm_episodes_end_with_discount_zero_when_terminated_and_one_when_truncated():
    env = DmTrenchDig(tiny(), seed=0)
    try:
        env.reset()
        step = env.step(env.action_spec().generate_value())
        while not step.last():
            step = env.step(env.action_spec().generate_value())
        assert step.discount == 1.0  # the budget of two digs truncated it
        assert env.step(env.action_spec().generate_value()).first()
    finally:
        env.close()


# -- seeding and reproduction -------------------------------------------------------------------
def test_the_planner_as_a_policy_reproduces_excavsim_trench(tmp_path, capsys):
    spec = tiny(dig_budget=3, seed=1)
    path = tmp_path / "tiny.yaml"
    path.write_text(yaml.safe_dump(spec))
    assert cli.main(["trench", "--spec", str(path)]) == 0
    printed = capsys.readouterr().out
    env = gym.make(DIG_ENV_ID, spec=spec)
    try:
        steps = run_env(env, PlannerPolicy(env.action_space), seed=1)
        result = env.unwrapped.result
    finally:
        env.close()
    assert len(steps) == 4 and all(s[4]["action_used"] for s in steps[1:])
    table = [line for line in format_episode(result).splitlines() if " wall; " not in line]
    assert all(line in printed.splitlines() for line in table if line)  # the same digs, the same summary
    direct = run_spec(EpisodeSpec(**spec))
    assert dig_rows(result) == dig_rows(direct)
    summary = {k: v for k, v in episode_summary(direct).items() if k not in ("planning_s", "wall_s")}
    assert steps[-1][4]["episode"] == summary


@pytest.mark.parametrize(("env_id", "kwargs"), [(DIG_ENV_ID, {}), (JOINT_ENV_ID, JOINT)])
def test_a_seed_reproduces_an_episode_exactly(env_id, kwargs):
    env = gym.make(env_id, spec=tiny(), **kwargs)
    try:
        runs = []
        for seed in (7, 7, 8):
            env.action_space.seed(11)
            runs.append(run_env(env, lambda obs, info: env.action_space.sample(), seed=seed))
    finally:
        env.close()
    assert len(runs[0]) == len(runs[1]) and data_equivalence(runs[0], runs[1], exact=True)
    assert not data_equivalence([s[0] for s in runs[0]], [s[0] for s in runs[2]], exact=True)


def test_reset_without_a_seed_starts_with_the_specs_seed_then_draws_reproducibly():
    a, b = gym.make(DIG_ENV_ID, spec=tiny(seed=2)), gym.make(DIG_ENV_ID, spec=tiny(seed=2))
    try:
        first = [env.reset()[0]["elevation"] for env in (a, b)]
        seeded = a.reset(seed=2)[0]["elevation"]
        second = [env.reset()[0]["elevation"] for env in (b, b)]
    finally:
        a.close()
        b.close()
    assert np.array_equal(first[0], first[1]) and np.array_equal(first[0], seeded)
    assert not np.array_equal(second[0], first[0]) and not np.array_equal(second[0], second[1])


# -- the dig environment's rules ----------------------------------------------------------------
def test_rewards_add_up_to_the_episodes_removed_soil_and_infeasible_actions_dig_the_nearest_cell():
    env = gym.make(DIG_ENV_ID, spec=tiny(), weights={"overdig_per_l": 3.0})
    try:
        low = env.action_space.low
        steps = run_env(env, lambda obs, info: low.copy(), seed=0)  # the corner cell is never feasible here
        result = env.unwrapped.result
    finally:
        env.close()
    infos = [s[4] for s in steps[1:]]
    assert all(i["action_used"] for i in infos)
    assert infos[0]["snapped_to_allowed"] and tuple(infos[0]["executed_cell"]) != (0, 0, 0)  # infeasible on the fill
    removed = sum(i["reward_terms"]["removed_l"] for i in infos)
    over = sum(i["reward_terms"]["overdig_l"] for i in infos)
    assert removed + over == pytest.approx(1000 * result.removed_m3, rel=1e-9)  # the loop's own measure
    assert sum(s[1] for s in steps) == pytest.approx(removed - 3.0 * over)
    first = infos[0]["dig"]
    assert first["kind"] == "planned" and first["outcome"] == "completed" and first["dug_l"] > 0
    assert not any(isinstance(v, float) and math.isnan(v) for i in infos for v in i["dig"].values())
    obs = steps[1][0]
    assert obs["outcome"] == 1 and obs["ft"][0] >= obs["ft"][1] > 0 and obs["digs_left"] == 1
    assert obs["goal_mask"].sum() > 0 and np.all(obs["goal_depth"][obs["goal_mask"] == 0] == 0)


def test_bad_actions_seeds_and_orders_are_refused_with_clear_errors():
    env = gym.make(DIG_ENV_ID, spec=tiny(), disable_env_checker=True)
    core = env.unwrapped.core
    try:
        with pytest.raises(EnvError, match="call reset"):
            core.step(env.action_space.low)
        env.reset(seed=0)
        for bad, message in (([2.0, 0.3], "shape"), ([2.0, math.nan, 0.1], "finite"),
                             ([5.0, 0.3, 0.1], "outside the action space"), ("k", "numbers|shape")):
            with pytest.raises(EnvError, match=message):
                env.step(bad)
        for seed in (-1, 2**32, 1.5, True):
            with pytest.raises(EnvError, match="seed"):
                env.reset(seed=seed)
        with pytest.raises(EnvError, match="options"):
            env.reset(options={"goal": "sand"})
        with pytest.raises(EnvError, match="weight"):
            gym.make(DIG_ENV_ID, spec=tiny(), weights={"removed_per_l": -1})
        with pytest.raises(EnvError, match="weight"):
            gym.make(DIG_ENV_ID, spec=tiny(), weights={"volume": 1})
        env.reset(seed=0)
        for _ in range(2):
            *_, truncated, _ = env.step(env.action_space.sample())
        assert truncated
        with pytest.raises(EnvError, match="ended"):
            env.step(env.action_space.sample())
    finally:
        env.close()
    env.close()  # twice is fine
    with pytest.raises(EnvError, match="closed"):
        core.reset(0)


# -- the joint environment's rules --------------------------------------------------------------
def test_joint_actions_drive_the_servos_and_the_episode_ends_on_time():
    env = gym.make(JOINT_ENV_ID, spec=tiny(), max_time_s=0.3, scan_period_s=0.1, start="home")
    try:
        obs0, _ = env.reset(seed=0)
        action = np.array([0.5, 1.0, 0.0, -1.0])  # waist and shoulder up, wrist pitch down
        n = 0
        truncated = False
        while not truncated:
            obs, reward, terminated, truncated, info = env.step(action)
            n += 1
            assert not terminated and math.isfinite(reward)
        with pytest.raises(EnvError, match="ended"):
            env.step(action)
        with pytest.raises(EnvError, match="outside"):
            env.reset(seed=0)
            env.step(np.array([0.0, 2.0, 0.0, 0.0]))
    finally:
        env.close()
    assert n == 30 and info["time_s"] == pytest.approx(0.3)
    dq = obs["q"] - obs0["q"]
    assert dq[0] > 0.05 and dq[1] > 0.05 and dq[3] < -0.05 and abs(dq[4]) < 0.01  # yaw held
    assert obs["patch"].shape == (2, 9, 9) and obs["time_left"] == pytest.approx(0.0, abs=1e-9)
    # the bucket is high over the soil at home: the terrain is below the tip everywhere
    assert np.all(obs["patch"][0] < 0)


def test_the_dig_environment_steps_its_episode_in_the_callers_thread_and_a_dropped_one_ends_it():
    import gc
    import threading
    import time

    from excavsim.handoff.episode import EpisodeObserver

    class Ends(EpisodeObserver):
        ended: list = []

        def finished(self, result):
            self.ended.append(result)

    before = set(threading.enumerate())
    env = gym.make(DIG_ENV_ID, spec=tiny(dig_budget=1), observer=Ends())
    t0 = time.perf_counter()
    env.reset(seed=0)
    busy = time.perf_counter() - t0
    assert set(threading.enumerate()) == before  # no worker: the episode waits as an object
    time.sleep(1.5)  # the agent thinks: not the episode's wall time
    t0 = time.perf_counter()
    _, _, terminated, truncated, info = env.step(env.unwrapped.core.action_low)
    busy += time.perf_counter() - t0
    assert terminated or truncated
    result = env.unwrapped.result
    assert result is not None and Ends.ended == [result]
    assert 0 < result.wall_time_s <= busy  # the wall clock ran only inside reset and step
    env.reset(seed=1)  # paused before its first dig
    del env
    gc.collect()
    assert Ends.ended[1:] == [None]  # a dropped environment ends its episode: the observers hear of it
    assert set(threading.enumerate()) == before
