"""One joint-level core for every machine (issue 41): :class:`~excavsim.envs.joint_core.JointCore` runs the
T3, the TB035 and the 25 t excavator through reset, step and the observation-space checks, on each goal
it has a place for; the machine's part of the observation follows its data; the vector entry point steps
any machine as N single environments do. Every episode is a fraction of a second."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from absl.testing import absltest
from dm_env import test_utils
from gymnasium.utils.env_checker import check_env, data_equivalence

import excavsim.envs  # noqa: F401 - registers the environments
from excavsim.envs import EXCAVATOR_JOINT_ENV_ID, EnvError, JointCore
from excavsim.envs.batched import BatchedJointEnv
from excavsim.envs.dm import DmJoint
from excavsim.envs.joint_region import REGIONS, JointRegion
from excavsim.envs.render import offscreen_error
from excavsim.errors import ConfigError
from excavsim.robot.machine import MACHINES
from excavsim.tasks.trench.envs import JOINT_DIG_ENV_ID, JOINT_ENV_ID, JOINT_GOAL
from excavsim.tasks.trench.envs.joint import JointTrench

# each machine on each goal it has a place for: the trench (any machine, its own pit's default trench)
# and the region (the excavators)
CASES = [(JOINT_DIG_ENV_ID, name) for name in MACHINES] + [(EXCAVATOR_JOINT_ENV_ID, name) for name in REGIONS]
SHORT = {"max_time_s": 0.2}


@pytest.mark.parametrize(("env_id", "machine"), CASES)
def test_the_one_core_passes_gymnasiums_checker_on_every_machine_and_goal(env_id, machine):
    env = gym.make(env_id, machine=machine, **SHORT)
    try:
        assert isinstance(env.unwrapped.core, JointCore) and env.unwrapped.core.machine.name == machine
        check_env(env.unwrapped, skip_render_check=offscreen_error() is not None)
    finally:
        env.close()


@pytest.mark.parametrize(("env_id", "machine"), CASES)
def test_every_machine_resets_and_steps_within_its_spaces_and_its_proprioception_is_its_own(env_id, machine):
    env = gym.make(env_id, machine=machine, **SHORT)
    m = MACHINES[machine]
    try:
        space = env.observation_space
        force = "ft" if m.force_reading == "ft" else "cylinder_force"
        assert space["q"].shape == space["qdot"].shape == (len(m.joints),) and force in space.spaces
        assert space["q"].high[0] == pytest.approx(m.angle_bound_rad)
        assert env.action_space.shape == (4,)
        obs, _ = env.reset(seed=2)
        assert space.contains(obs)
        rng = np.random.default_rng(2)
        steps = 0
        while True:
            obs, reward, terminated, truncated, info = env.step(rng.uniform(-1, 1, 4).astype(np.float32))
            steps += 1
            assert space.contains(obs), {k: v for k, v in obs.items() if not space[k].contains(v)}
            assert np.isfinite(reward) and reward == pytest.approx(sum(info["reward_terms"].values()), abs=1e-12)
            if terminated or truncated:
                break
        # the episode's length is the machine's control period: 10 ms on the T3, 20 ms on an excavator
        assert truncated and steps == round(0.2 / env.unwrapped.core.control_dt)
        with pytest.raises(EnvError, match="reset"):
            env.step(np.zeros(4, np.float32))
    finally:
        env.close()


def test_the_same_seed_gives_the_same_episode_on_an_excavators_trench():
    env = gym.make(JOINT_ENV_ID, machine="tb035", max_time_s=0.3, scan_period_s=0.1)
    actions = np.random.default_rng(4).uniform(-1, 1, (15, 4)).astype(np.float32)

    def run(seed):
        out = [env.reset(seed=seed)]
        out += [env.step(a) for a in actions]
        return out

    try:
        a, b, c = run(3), run(3), run(4)
    finally:
        env.close()
    assert data_equivalence(a, b, exact=True) and not data_equivalence(a[0], c[0], exact=True)


def test_an_excavator_starts_near_the_soil_at_rest_where_its_tip_was_placed():
    env = gym.make(JOINT_DIG_ENV_ID, machine="tb035")
    try:
        obs, info = env.reset(seed=0, options={"start_x_m": 3.0, "start_height_m": 0.05, "start_pitch_deg": 70.0})
        goal = env.unwrapped.core.resolved.goal
        x, z, pitch = info["start_pose"]
        assert (x, z) == pytest.approx((3.0, goal.surface_z_m + 0.05))
        np.testing.assert_allclose(obs["tip"], [3.0, 0.0, goal.surface_z_m + 0.05, np.radians(70.0)], atol=2e-3)
        assert np.abs(obs["qdot"]).max() < 1e-9  # at rest: no simulated move
        for _ in range(10):  # holding still: the servos hold the arm against its droop
            obs, *_ = env.step(np.zeros(4, np.float32))
        assert abs(obs["tip"][2] - (goal.surface_z_m + 0.05)) < 0.002
    finally:
        env.close()


def test_keywords_pick_the_machine_soil_and_seed_and_bad_ones_are_refused_by_name():
    core = JointCore(goal="region")  # the region's defaults: the TB035 in dry sand
    assert (core.spec.machine, core.spec.soil) == ("tb035", "dry_sand") and core.max_time_s == 20.0
    core = JointCore({"machine": "excavator_25t", "seed": 9}, goal="region", soil="testbed_sand")
    assert (core.machine.name, core.spec.soil, core.spec.seed) == ("excavator_25t", "testbed_sand", 9)
    assert JointCore().machine.name == "t3" and JointCore(machine="tb035").machine.name == "tb035"
    with pytest.raises(EnvError, match="region for machines tb035, excavator_25t; given machine 't3'"):
        JointCore(goal="region", machine="t3")
    with pytest.raises(EnvError, match="goal must be one of 'trench', 'region' or an entry point module:Class"):
        JointCore(goal="pit")
    with pytest.raises(EnvError, match="goal 'excavsim.nowhere:Pit': cannot load"):
        JointCore(goal="excavsim.nowhere:Pit")
    with pytest.raises(EnvError, match=r"unknown setting\(s\) \['start'\] of the region goal"):
        JointCore(goal="region", start="home")
    with pytest.raises(ConfigError, match="machine 'loader' does not do task trench; allowed: t3, tb035"):
        JointCore(machine="loader")


def test_a_goal_is_named_by_its_task_or_its_entry_point_or_given_as_a_class():
    """The core names no task: a task's goal is found through its plug-in's environments (the default task's
    without a goal), the region is the platform's own."""
    goals = excavsim.envs.joint_goals()
    assert (goals["trench"], goals["region"]) == (JOINT_GOAL, "excavsim.envs.joint_region:JointRegion")
    for goal in (None, "trench", JOINT_GOAL, JointTrench):
        assert type(JointCore(goal=goal).goal) is JointTrench
    for goal in ("region", goals["region"], JointRegion):
        assert type(JointCore(goal=goal).goal) is JointRegion
    assert gym.spec(JOINT_DIG_ENV_ID).kwargs["goal"] == JOINT_GOAL


def test_the_vector_entry_point_steps_an_excavator_as_n_single_environments_do():
    """Any machine and goal through the batched environment's copy-by-copy path, with its autoreset."""
    n, seeds = 2, [5, 6]
    venv = gym.make_vec(EXCAVATOR_JOINT_ENV_ID, num_envs=n, max_time_s=0.1)
    singles = [gym.make(EXCAVATOR_JOINT_ENV_ID, max_time_s=0.1) for _ in range(n)]
    try:
        assert isinstance(venv.unwrapped, BatchedJointEnv) and not venv.unwrapped._compiled
        ov, iv = venv.reset(seed=seeds)
        for i, (env, s) in enumerate(zip(singles, seeds)):
            o, info = env.reset(seed=s)
            assert data_equivalence(o, {k: v[i] for k, v in ov.items()}, exact=True)
            assert info["region_soil_m3"] == iv["region_soil_m3"][i]
        rng = np.random.default_rng(1)
        for t in range(5):  # 0.1 s at 50 Hz
            actions = rng.uniform(-1, 1, (n, 4)).astype(np.float32)
            ov, rv, tv, trv, iv = venv.step(actions)
            for i, env in enumerate(singles):
                o, r, te, tr, info = env.step(actions[i])
                assert data_equivalence(o, {k: v[i] for k, v in ov.items()}, exact=True), (t, i)
                assert (r, te, tr) == (rv[i], tv[i], trv[i]) and info["removed_m3"] == iv["removed_m3"][i]
        assert np.all(trv)
        ov, rv, tv, trv, _ = venv.step(np.zeros((n, 4), np.float32))  # NEXT_STEP autoreset
        assert np.all(rv == 0) and not np.any(tv | trv) and np.all(ov["time_left"] == pytest.approx(0.1))
    finally:
        venv.close()
        for env in singles:
            env.close()


class DmRegionTest(test_utils.EnvironmentTestMixin, absltest.TestCase):
    """dm_env's own checks of the joint level on an excavator's region; 20 actions pass the ends of 0.1 s
    (5-step) episodes."""

    def make_object_under_test(self):
        return DmJoint(goal="region", seed=5, max_time_s=0.1)
