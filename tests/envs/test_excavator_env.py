"""``excavsim/ExcavatorJoint-v0``: the TB035's four valves at 50 Hz (Gymnasium's checker, seeding, the actions'
effect on the joints, the reward's account of the region's soil, the time limit, bad input).
Stable-Baselines3's checker runs it in tests/envs/test_rl.py with every registered environment."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env, data_equivalence

import excavsim.envs  # noqa: F401 - registers the environments
from excavsim.envs import EXCAVATOR_JOINT_ENV_ID, EnvError
from excavsim.envs.render import offscreen_error

DIG = np.array([0.0, -0.6, 0.5, 0.4], np.float32)  # boom down, stick in, bucket curling: the bucket cuts


def test_gymnasium_check_env_passes():
    env = gym.make(EXCAVATOR_JOINT_ENV_ID, max_time_s=0.3)
    try:
        check_env(env.unwrapped, skip_render_check=offscreen_error() is not None)
    finally:
        env.close()
    assert env.observation_space["q"].dtype == np.float32 and env.action_space.shape == (4,)


def run(env, seed, actions):
    steps = [env.reset(seed=seed)]
    for a in actions:
        steps.append(env.step(a))
        if steps[-1][2] or steps[-1][3]:
            break
    return steps


def test_the_same_seed_gives_the_same_episode_and_another_seed_another():
    env = gym.make(EXCAVATOR_JOINT_ENV_ID, max_time_s=1.0)
    actions = np.random.default_rng(3).uniform(-1, 1, (50, 4)).astype(np.float32)
    try:
        a, b, c = run(env, 5, actions), run(env, 5, actions), run(env, 6, actions)
    finally:
        env.close()
    assert len(a) == len(b) == 51 and data_equivalence(a, b, exact=True)
    assert not data_equivalence([s[0] for s in a], [s[0] for s in c], exact=True)


def test_each_valve_drives_its_joint():
    """A full valve on one function moves that joint the stated way and the others much less."""
    env = gym.make(EXCAVATOR_JOINT_ENV_ID, max_time_s=2.0)
    try:
        for j, sign in ((0, 1.0), (0, -1.0), (1, 1.0), (2, -1.0), (3, -1.0)):
            obs, _ = env.reset(seed=0)
            q0 = obs["q"].copy()
            a = np.zeros(4, np.float32)
            a[j] = sign
            for _ in range(25):  # 0.5 s
                obs, *_ = env.step(a)
            dq = obs["q"] - q0
            # cylinders extend with +1: boom up, stick and bucket in (their angles grow negative, Table 4.2)
            expected = sign if j < 2 else -sign
            assert np.sign(dq[j]) == expected and abs(dq[j]) > 0.05, (j, sign, dq)
            assert np.abs(np.delete(dq, j)).max() < 0.5 * abs(dq[j])
    finally:
        env.close()


def test_a_dig_is_rewarded_by_the_soil_it_removes_and_the_episode_is_truncated_on_time():
    env = gym.make(EXCAVATOR_JOINT_ENV_ID, max_time_s=3.0)
    try:
        obs, info = env.reset(seed=0)
        start = info["region_soil_m3"]
        total, terms, steps = 0.0, {}, 0
        while True:
            obs, r, terminated, truncated, info = env.step(DIG)
            total += r
            for k, v in info["reward_terms"].items():
                terms[k] = terms.get(k, 0.0) + v
            steps += 1
            if terminated or truncated:
                break
        with pytest.raises(EnvError, match="reset"):
            env.step(DIG)
    finally:
        env.close()
    assert truncated and not terminated and steps == 150  # 3 s at 50 Hz
    assert terms["removed"] == pytest.approx(1000.0 * (start - info["region_soil_m3"]), rel=1e-9, abs=1e-9)
    assert info["removed_m3"] > 0.01 and obs["bucket_soil"][0] > 0.01  # the bucket cut into the region
    assert total == pytest.approx(sum(terms.values()))
    assert terms["removed"] > 10.0  # litres


def test_bad_input_is_refused_with_clear_errors():
    env = gym.make(EXCAVATOR_JOINT_ENV_ID, max_time_s=0.2)
    try:
        env.reset(seed=0)
        with pytest.raises(EnvError, match="shape"):
            env.step(np.zeros(3, np.float32))
        with pytest.raises(EnvError):
            env.step(np.array([2.0, 0, 0, 0], np.float32))
        with pytest.raises(EnvError, match="seed"):
            env.reset(seed=-1)
        with pytest.raises(EnvError, match="options"):
            env.reset(seed=0, options={"start": "home"})
    finally:
        env.close()
    with pytest.raises(EnvError, match="machine"):
        gym.make(EXCAVATOR_JOINT_ENV_ID, machine="t3")
    with pytest.raises(EnvError, match="reward weight"):
        gym.make(EXCAVATOR_JOINT_ENV_ID, weights={"cut_per_l": 1.0})
