"""Steps per second of both environments, in CPU time (``time.process_time()``) and wall time.

    python examples/step_rates.py [--digs N] [--joint-steps N] [--tiny]

TrenchDig-v0 runs the planner policy on the default episode (the sand trench; each step scans,
plans, digs and settles); TrenchJoint-v0 runs uniform random set-point rates from its near-soil start
(a rescan every simulated second included). Resets are timed apart. ``--tiny`` uses the coarse
scans and planner grid of configs/campaigns/tiny.yaml on the small trench, as the tests do.
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym

import excavsim.envs  # noqa: F401  (registers the environments)
from excavsim.envs.dig_env import PlannerPolicy

TINY = {"goal": "small", "sensing": {"map": {"n_scans": 1}, "scanner": {"n_azimuth": 60, "n_elevation": 60}},
        "planner": {"grid": {"k_min_m": 1.8, "k_max_m": 2.6, "k_step_m": 0.2, "alpha_step_deg": 15.0,
                             "d1_step_m": 0.04}}}


def rate(env: gym.Env, policy, steps: int, seed: int = 0) -> tuple[float, float, float, int]:
    """(CPU s per reset, CPU steps/s, wall steps/s, steps) over ``steps`` steps, resetting when an episode ends."""
    reset_cpu, n, cpu, wall = 0.0, 0, 0.0, 0.0
    c0 = time.process_time()
    obs, info = env.reset(seed=seed)
    reset_cpu += time.process_time() - c0
    resets = 1
    while n < steps:
        c0, w0 = time.process_time(), time.perf_counter()
        obs, reward, terminated, truncated, info = env.step(policy(obs, info))
        cpu += time.process_time() - c0
        wall += time.perf_counter() - w0
        n += 1
        if terminated or truncated:
            c0 = time.process_time()
            obs, info = env.reset(seed=seed + resets)
            reset_cpu += time.process_time() - c0
            resets += 1
    return reset_cpu / resets, n / cpu, n / wall, n


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--digs", type=int, default=20, help="TrenchDig-v0 steps to time (default 20)")
    parser.add_argument("--joint-steps", type=int, default=5000, help="TrenchJoint-v0 steps to time (default 5000)")
    parser.add_argument("--tiny", action="store_true", help="the small trench with coarse scans and planner grid")
    args = parser.parse_args()
    spec = TINY if args.tiny else None
    dig = gym.make("excavsim/TrenchDig-v0", spec=spec)
    joint = gym.make("excavsim/TrenchJoint-v0", spec=spec)
    try:
        planner = PlannerPolicy(dig.action_space)
        r, cpu, wall, n = rate(dig, planner, args.digs)
        print(f"TrenchDig-v0   {cpu:9.2f} steps/s CPU ({wall:8.2f} wall) over {n} digs; reset {r:.2f} s CPU")
        joint.action_space.seed(0)
        r, cpu, wall, n = rate(joint, lambda obs, info: joint.action_space.sample(), args.joint_steps)
        print(f"TrenchJoint-v0 {cpu:9.0f} steps/s CPU ({wall:8.0f} wall) over {n} steps "
              f"({n * joint.unwrapped.core.control_dt:.0f} s simulated); reset {r:.2f} s CPU")
    finally:
        dig.close()
        joint.close()


if __name__ == "__main__":
    main()
