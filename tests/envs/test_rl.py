"""The environments as a reinforcement-learning user meets them (issue 36): Stable-Baselines3's
``check_env``, ``make_vec_env`` and a PPO smoke run on every registered environment, Gymnasium's
checker on the single-dig task, rendering, the near-soil start and the reward's terms, and the
batched vector environment against N single ones, step for step.

Stable-Baselines3 is an optional extra (``pip install -e .[rl]``): its tests skip with the reason
when it is missing, and fail instead when ``EXCAVSIM_REQUIRE_RL=1`` (CI installs the extra). The
frame test needs a GL backend for MuJoCo's offscreen renderer (``MUJOCO_GL=egl``); it skips where
none works, and fails instead when ``EXCAVSIM_REQUIRE_RENDER=1``. Every episode is tiny.
"""

from __future__ import annotations

import copy
import os

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env

import excavsim.envs
from excavsim.envs import ENV_IDS, EXCAVATOR_JOINT_ENV_ID, EnvError
from excavsim.envs.batched import BatchedJointEnv, watch_ok
from excavsim.envs.render import RenderModeError, offscreen_error
from excavsim.tasks.pile_loading.config_planar import load_loading_config
from excavsim.tasks.pile_loading.envs import LOAD_DIG_ENV_ID
from excavsim.tasks.trench.envs import DIG_ENV_ID, JOINT_DIG_ENV_ID, JOINT_ENV_ID

_LOADING = load_loading_config()
TINY = {
    "name": "tiny", "goal": "small", "dig_budget": 2, "seed": 0,
    "sensing": {"map": {"n_scans": 1}, "scanner": {"n_azimuth": 60, "n_elevation": 60}},
    "planner": {"grid": {"k_min_m": 1.8, "k_max_m": 2.6, "k_step_m": 0.2, "alpha_step_deg": 15.0, "d1_step_m": 0.04}},
}
SHORT = {  # each environment with a tiny spec and, at the joint level, 0.3 s episodes
    DIG_ENV_ID: {"spec": {**TINY, "dig_budget": 1}},
    JOINT_ENV_ID: {"spec": TINY, "max_time_s": 0.3, "scan_period_s": 0.2},
    JOINT_DIG_ENV_ID: {"spec": TINY, "max_time_s": 0.3},
    EXCAVATOR_JOINT_ENV_ID: {"max_time_s": 0.3},
    LOAD_DIG_ENV_ID: {"spec": {"name": "tiny", "dig_budget": 1, "seed": 0, "pile_loading": {  # a 0.6 m pile, one coarse scan
        "pile": {"height": 0.6, "top": 0.3, "foot": 1.5}, "n_scans": 1, "scanner": {"n_azimuth": 80, "n_elevation": 20}}},
        "loading_config": _LOADING.model_copy(update={"planner": _LOADING.planner.model_copy(  # a coarse planner grid
            update={"k_step": 0.2, "alpha_deg": [-30.0, 40.0, 10.0]})})},
}
DIG_DOWN = np.array([0.0, -0.3, -0.4, 0.3], np.float32)  # shoulder and elbow down, wrist curling: the bucket cuts


def kwargs_of(env_id: str) -> dict:
    return copy.deepcopy(SHORT[env_id])


def _sb3():
    """Stable-Baselines3, or a skip with the reason (a failure with EXCAVSIM_REQUIRE_RL=1)."""
    try:
        import stable_baselines3
    except ImportError as exc:
        if os.environ.get("EXCAVSIM_REQUIRE_RL") == "1":
            pytest.fail(f"EXCAVSIM_REQUIRE_RL=1 but Stable-Baselines3 does not import ({exc}); pip install -e .[rl]")
        pytest.skip(f"Stable-Baselines3 is not installed (the optional extra: pip install -e .[rl]): {exc}")
    return stable_baselines3


def test_every_environment_is_registered_and_the_joint_ones_have_the_batched_vector_entry_point():
    assert excavsim.envs.register()
    for env_id in ENV_IDS:
        assert env_id in gym.envs.registration.registry
    for env_id in (JOINT_ENV_ID, JOINT_DIG_ENV_ID, EXCAVATOR_JOINT_ENV_ID):
        assert gym.spec(env_id).vector_entry_point == "excavsim.envs.batched:BatchedJointEnv"
        assert gym.spec(env_id).entry_point == "excavsim.envs.joint_env:JointEnv"  # one face for every machine
    assert gym.spec(JOINT_DIG_ENV_ID).kwargs["max_time_s"] == 6.0  # 600 steps, one dig


# -- Stable-Baselines3, unmodified --------------------------------------------------------------
# deliberate, docs/environments.md: TrenchDig's default action is in metres (normalize_action=True is
# [-1, 1]); the joint level's ``patch`` is a 2-channel height map in metres, not an image to a CNN
@pytest.mark.filterwarnings("ignore:.*symmetric and normalized")
@pytest.mark.filterwarnings("ignore:It seems that your observation space patch is an image")
@pytest.mark.filterwarnings("ignore:The minimal resolution for an image")
@pytest.mark.parametrize("env_id", ENV_IDS)
def test_sb3_check_env_passes_on_every_registered_environment(env_id):
    _sb3()
    from stable_baselines3.common.env_checker import check_env

    env = gym.make(env_id, **kwargs_of(env_id))
    try:
        check_env(env.unwrapped, warn=True)
    finally:
        env.close()


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_sb3_make_vec_env_builds_every_registered_environment(env_id):
    _sb3()
    from stable_baselines3.common.env_util import make_vec_env

    # make_vec_env asks for render_mode="rgb_array" and falls back only on a TypeError: it must be accepted
    venv = make_vec_env(env_id, n_envs=2, seed=3, env_kwargs=kwargs_of(env_id))
    try:
        assert venv.get_attr("render_mode") == ["rgb_array", "rgb_array"]
        obs = venv.reset()
        obs, rewards, dones, infos = venv.step(np.array([venv.action_space.sample() for _ in range(2)]))
        assert rewards.shape == (2,) and np.all(np.isfinite(rewards))
        assert all(v.shape[0] == 2 for v in obs.values())
    finally:
        venv.close()


def test_a_256_step_ppo_run_with_the_default_policy():
    _sb3()
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env

    torch.set_num_threads(1)
    venv = make_vec_env(JOINT_DIG_ENV_ID, n_envs=2, seed=0, env_kwargs=kwargs_of(JOINT_DIG_ENV_ID))
    try:
        model = PPO("MultiInputPolicy", venv, n_steps=128, batch_size=64, n_epochs=1, seed=0, device="cpu")
        model.learn(total_timesteps=256)
        assert model.num_timesteps == 256
        action, _ = model.predict(venv.reset(), deterministic=True)
        assert action.shape == (2, 4) and np.all(np.abs(action) <= 1)
    finally:
        venv.close()


def test_sac_with_the_default_policy_learns_a_few_steps():
    _sb3()
    import torch
    from stable_baselines3 import SAC
    from stable_baselines3.common.env_util import make_vec_env

    torch.set_num_threads(1)
    venv = make_vec_env(JOINT_DIG_ENV_ID, n_envs=1, seed=0, env_kwargs=kwargs_of(JOINT_DIG_ENV_ID))
    try:
        model = SAC("MultiInputPolicy", venv, learning_starts=32, batch_size=32, seed=0, device="cpu")
        model.learn(total_timesteps=64)
        assert model.num_timesteps == 64 and model.replay_buffer.size() == 64
    finally:
        venv.close()


# -- Gymnasium -----------------------------------------------------------------------------------
def test_gymnasium_env_checker_passes_on_the_single_dig_task():
    env = gym.make(JOINT_DIG_ENV_ID, **kwargs_of(JOINT_DIG_ENV_ID))
    try:
        gym_check_env(env.unwrapped, skip_render_check=offscreen_error() is not None)
    finally:
        env.close()


def test_spaces_are_float32_with_no_zero_dimensional_box():
    for env_id in ENV_IDS:
        env = gym.make(env_id, **kwargs_of(env_id))
        try:
            assert env.action_space.dtype == np.float32, env_id
            for name, space in env.observation_space.spaces.items():
                if isinstance(space, gym.spaces.Box):
                    assert space.dtype == np.float32 and space.shape != (), (env_id, name)
        finally:
            env.close()
    env = gym.make(DIG_ENV_ID, spec=TINY, normalize_action=True)
    try:
        assert np.all(env.action_space.low == -1) and np.all(env.action_space.high == 1)
    finally:
        env.close()


# -- rendering -------------------------------------------------------------------------------------
def test_render_mode_none_by_default_and_an_unknown_mode_is_a_type_error():
    env = gym.make(JOINT_DIG_ENV_ID, **kwargs_of(JOINT_DIG_ENV_ID))
    try:
        assert env.unwrapped.render_mode is None and env.unwrapped.render() is None
    finally:
        env.close()
    for env_id in ENV_IDS:  # ("human" would be Gymnasium's HumanRendering wrapper over "rgb_array")
        with pytest.raises(TypeError, match="render_mode must be None or one of 'rgb_array'; given 'ansi'") as info:
            gym.make(env_id, render_mode="ansi", **kwargs_of(env_id))
        assert isinstance(info.value, RenderModeError) and isinstance(info.value, EnvError)


def test_rgb_array_frames_where_a_gl_backend_works():
    why = offscreen_error()
    if why is not None:
        if os.environ.get("EXCAVSIM_REQUIRE_RENDER") == "1":
            pytest.fail(f"EXCAVSIM_REQUIRE_RENDER=1 but MuJoCo's offscreen renderer does not work: {why}")
        pytest.skip(f"no GL backend for MuJoCo's offscreen renderer (MUJOCO_GL={os.environ.get('MUJOCO_GL')}): {why}")
    env = gym.make(JOINT_DIG_ENV_ID, render_mode="rgb_array", render_size=(160, 120), **kwargs_of(JOINT_DIG_ENV_ID))
    try:
        env.reset(seed=0)
        frame = env.render()
        assert frame.shape == (120, 160, 3) and frame.dtype == np.uint8 and frame.std() > 5  # not a blank frame
    finally:
        env.close()


def test_without_a_gl_backend_the_first_frame_raises_an_error_naming_it():
    if offscreen_error() is None:
        pytest.skip("a GL backend works here: the error path cannot be reached")
    env = gym.make(JOINT_DIG_ENV_ID, render_mode="rgb_array", **kwargs_of(JOINT_DIG_ENV_ID))
    try:
        env.reset(seed=0)  # creating and resetting need no GL
        with pytest.raises(EnvError, match=r"MUJOCO_GL=.* gave none.*MUJOCO_GL=egl"):
            env.render()
    finally:
        env.close()


# -- the single-dig task ---------------------------------------------------------------------------
def test_the_dig_task_starts_just_above_the_soil_and_its_reward_is_the_sum_of_its_terms():
    env = gym.make(JOINT_DIG_ENV_ID, spec=TINY, max_time_s=1.5)
    try:
        obs, info = env.reset(seed=1)
        goal = env.unwrapped.core.resolved.goal
        x, z, _ = info["start_pose"]
        assert goal.near_x_m <= x <= goal.far_x_m and 0.01 <= z - goal.surface_z_m <= 0.06
        assert -0.08 < obs["patch"][0, 4, 4] < 0  # the scanned terrain is just below the tip
        obs2, info2 = env.reset(seed=1)
        np.testing.assert_array_equal(info["start_pose"], info2["start_pose"])  # drawn from the seed
        total, removed = 0.0, 0.0
        for _ in range(150):
            obs, reward, terminated, truncated, info = env.step(DIG_DOWN)
            assert reward == pytest.approx(sum(info["reward_terms"].values()), abs=1e-12)
            total += reward
        assert truncated and info["removed_l"] > 1.0 and total > 1.0  # the bucket cut soil, and was paid for it
        # holding still earns nothing (the shaping is a potential: its sum is the change of depth)
        env.reset(seed=1)
        still = [env.step(np.zeros(4, np.float32))[1] for _ in range(100)]
        assert abs(sum(still)) < 0.05
        with pytest.raises(EnvError, match="unknown reset option"):
            env.reset(seed=1, options={"start_z": 0.1})
        with pytest.raises(EnvError, match="start_height_m must be a number"):
            env.reset(seed=1, options={"start_height_m": 7.0})
    finally:
        env.close()


# -- the batched vector environment ----------------------------------------------------------------
def test_the_batched_env_steps_exactly_as_n_single_envs_and_autoresets_next_step():
    n, seeds = 3, [5, 6, 7]
    kwargs = {"spec": TINY, "max_time_s": 0.6}
    venv = gym.make_vec(JOINT_DIG_ENV_ID, num_envs=n, **kwargs)  # the default mode: the vector entry point
    singles = [gym.make(JOINT_DIG_ENV_ID, **kwargs) for _ in range(n)]
    try:
        assert isinstance(venv.unwrapped, BatchedJointEnv)
        ov, _ = venv.reset(seed=seeds)
        assert venv.unwrapped._batch.shared  # the copies' trench measures are taken together (the batched path)
        for i, (env, s) in enumerate(zip(singles, seeds)):
            o, _ = env.reset(seed=s)
            for k in o:
                np.testing.assert_array_equal(o[k], ov[k][i])
        rng = np.random.default_rng(0)
        removed = np.zeros(n)
        for t in range(60):
            actions = np.clip(DIG_DOWN + rng.normal(0, 0.3, (n, 4)), -1, 1).astype(np.float32)
            ov, rv, tv, trv, iv = venv.step(actions)
            for i, env in enumerate(singles):
                o, r, te, tr, info = env.step(actions[i])
                for k in o:
                    np.testing.assert_array_equal(o[k], ov[k][i], err_msg=f"step {t}, copy {i}, {k}")
                assert (r, te, tr) == (rv[i], tv[i], trv[i])
                assert info["removed_l"] == iv["removed_l"][i]
                removed[i] = info["removed_l"]
        assert np.all(trv) and np.all(removed > 0)  # all cut soil (the batched soil kernel ran), all ended
        ov, rv, tv, trv, _ = venv.step(np.zeros((n, 4), np.float32))  # NEXT_STEP autoreset
        assert np.all(rv == 0) and not np.any(tv | trv) and np.all(ov["time_left"] == pytest.approx(0.6))
        with pytest.raises(EnvError, match=r"actions must be finite rates in \[-1, 1\]"):
            venv.step(np.full((n, 4), 2.0, np.float32))
    finally:
        venv.close()
        for env in singles:
            env.close()


def test_the_batched_watchdog_passes_only_steps_the_worlds_watchdog_would_pass():
    """watch_ok flags (for the world's own watchdog to word) a grown warning counter, a clock that
    did not advance by the control period, a non-finite or huge joint state; a fine step passes."""
    from numba.typed import List

    n = 6
    counts = List([np.zeros(8, np.int32) for _ in range(n)])
    base = List([np.zeros(8, np.int64) for _ in range(n)])
    qpos = List([np.zeros(7) for _ in range(n)])
    qvel = List([np.zeros(6) for _ in range(n)])
    before, after = np.zeros(n), np.full(n, 0.01)
    counts[1][3] = 1
    after[2] = 0.0  # MuJoCo reset the state
    qpos[3][2] = np.nan
    qvel[4][0] = 1e305  # finite, but sums of such could overflow
    ok = np.zeros(n, dtype=np.bool_)
    stepped = np.ones(n, dtype=np.bool_)
    stepped[5] = False
    watch_ok(stepped, counts, base, qpos, qvel, before, after, 0.01, 0.001, ok)
    assert ok.tolist() == [True, False, False, False, False, False]


def test_sync_and_async_make_vec_still_work_on_the_dig_task():
    import multiprocessing

    multiprocessing.set_forkserver_preload(["excavsim.envs.joint_env"])
    for mode, vector_kwargs in (("sync", {}), ("async", {"context": "forkserver"})):
        venv = gym.make_vec(JOINT_DIG_ENV_ID, num_envs=2, vectorization_mode=mode, vector_kwargs=vector_kwargs,
                            **kwargs_of(JOINT_DIG_ENV_ID))
        try:
            obs, _ = venv.reset(seed=[1, 2])
            obs, reward, *_ = venv.step(np.zeros((2, 4), np.float32))
            assert obs["q"].shape == (2, 6) and reward.shape == (2,) and np.all(np.isfinite(reward))
        finally:
            venv.close()
