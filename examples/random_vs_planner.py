"""A random policy and the planner as a policy through ``excavsim/TrenchDig-v0``, side by side.

    python examples/random_vs_planner.py [--episodes N] [--goal NAME] [--dig-budget N] [--seed S]

Each episode runs once per policy with the same seed (the same soil, sensor noise and scanner
drift). The random policy samples the action space uniformly; the environment snaps each sample
to the planner's grid and digs the nearest feasible cell. The planner policy takes the planner's
choice on the same map (``info["planner_action"]``), which reproduces ``excavsim trench``. Prints
per episode the return, the digs, the soil removed (true terrain), how the episode ended, and the
CPU time per step.
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym

import excavsim.envs  # noqa: F401  (registers the environments)
from excavsim.envs.dig_env import PlannerPolicy


def run(env: gym.Env, policy, seed: int) -> dict:
    """One episode of ``policy(obs, info)``: its return, digs, removed fraction, end and CPU per step."""
    cpu = time.process_time()
    obs, info = env.reset(seed=seed)
    total, steps, over = 0.0, 0, False
    while not over:
        obs, reward, terminated, truncated, info = env.step(policy(obs, info))
        total += reward
        steps += 1
        over = terminated or truncated
    episode = info["episode"]
    return {"return": total, "digs": episode["digs"], "removed": episode["removed_fraction"], "end": episode["end"],
            "cpu_per_step": (time.process_time() - cpu) / steps}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=3, help="episodes per policy (default 3)")
    parser.add_argument("--goal", default="small", help="trench goal of configs/trenches (default small)")
    parser.add_argument("--dig-budget", type=int, default=6, help="digs per episode (default 6)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the first episode (default 0)")
    args = parser.parse_args()
    env = gym.make("excavsim/TrenchDig-v0", spec={"goal": args.goal, "dig_budget": args.dig_budget})
    env.action_space.seed(args.seed)
    policies = {"random": lambda obs, info: env.action_space.sample(), "planner": PlannerPolicy(env.action_space)}
    print(f"TrenchDig-v0: {args.goal} trench, {args.dig_budget} digs at most, {args.episodes} episodes per policy")
    print(f"{'seed':>4} | {'random: return':>14} {'digs':>4} {'removed':>7} {'end':<8} | "
          f"{'planner: return':>15} {'digs':>4} {'removed':>7} {'end':<8}")
    sums = {name: 0.0 for name in policies}
    cpu = {name: [] for name in policies}
    try:
        for seed in range(args.seed, args.seed + args.episodes):
            cells = []
            for name, policy in policies.items():
                r = run(env, policy, seed)
                sums[name] += r["return"]
                cpu[name].append(r["cpu_per_step"])
                cells.append(f"{r['return']:14.1f} {r['digs']:4d} {r['removed']:7.0%} {r['end']:<8}")
            print(f"{seed:>4} | {cells[0]} | {' ' + cells[1]}")
    finally:
        env.close()
    n = args.episodes
    print(f"mean return: random {sums['random'] / n:.1f}, planner {sums['planner'] / n:.1f}; CPU per dig: random "
          f"{sum(cpu['random']) / n:.2f} s, planner {sum(cpu['planner']) / n:.2f} s")


if __name__ == "__main__":
    main()
