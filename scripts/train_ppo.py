"""The PPO baseline of the single-dig task: train Stable-Baselines3's PPO on ``excavsim/TrenchJointDig-v0``
on two CPU cores, evaluate it against a random policy and the scripted executor on 8 seeds, and write
the table and the learning curve into a docs note.

Run (needs ``pip install -e .[envs,rl]``)::

    MUJOCO_GL=disable python scripts/train_ppo.py --minutes 35 --out docs/notes/2026-12-02-ppo-baseline.md

The recipe (docs/environments.md explains each choice): one torch thread (``torch.set_num_threads(1)``:
the default of one thread per core halves the step rate on a 2-core machine), 8 copies of the
environment stepped in this process (``DummyVecEnv``: the environment's step is ~0.5 ms, a worker
process per copy costs more in pickling than it gains on 2 shared cores), observations and rewards
scaled by ``VecNormalize`` (the F/T reading is in newtons, the angles in radians), PPO's default
``MultiInputPolicy`` (two 64-unit layers) with the initial action noise lowered to std 0.6.

Evaluation, each on the same 8 seeds (1000-1007, none of them a training episode's first seed):
PPO deterministic; a random policy (uniform actions); the scripted executor, which plans the
dig on the reset's scanned map with the trenching planner and runs it with the dig executor from
the same start (:class:`~excavsim.execution.dig.DigExecutor`, as ``excavsim trench`` digs), its
reward summed by the environment's own terms, over the same 600 steps and over its whole dig.
"""

from __future__ import annotations

import argparse
import json
import math
import pathlib
import sys
import time

import numpy as np

SEEDS = tuple(range(1000, 1008))
if __name__ == "__main__" and "--quick" in sys.argv:  # a smoke run of the script itself
    SEEDS = SEEDS[:2]
ENV_ID = "excavsim/TrenchJointDig-v0"


def run_policy(env, policy, seed: int) -> dict:
    """One episode of ``policy(obs) -> action``: return, soil removed, over-dig, load, steps."""
    obs, info = env.reset(seed=seed)
    total, steps, done = 0.0, 0, False
    while not done:
        obs, reward, terminated, truncated, info = env.step(policy(obs))
        total += reward
        steps += 1
        done = terminated or truncated
    return {"return": total, "removed_l": info["removed_l"], "overdig_l": info["overdig_l"],
            "load_l": info["load_l"], "spoil_l": info["spoil_l"], "steps": steps}


def run_scripted(env, seed: int) -> dict:
    """The planner's dig run by the dig executor from the reset's start, rewarded by the environment's
    terms every control step (a step hook): the figures at the horizon and at the end of the dig."""
    from excavsim.handoff.goal import goal_profile
    from excavsim.handoff.dig import DigPlan
    from excavsim.tasks.trench.digs import PlannedDigs

    env.reset(seed=seed)
    core = env.unwrapped.core
    sim, rig, goal = core.sim, core.rig, core.resolved.goal
    horizon = round(core.max_time_s / core.control_dt)
    log = {"return": 0.0, "steps": 0}
    at_horizon: dict = {}

    def hook(_sim):
        _obs, reward, _te, _tr, info = core.after_step(sim.observe())
        log["return"] += reward
        log["steps"] += 1
        log["info"] = info
        if log["steps"] == horizon:
            at_horizon.update(log)

    choice = PlannedDigs(None).choose(rig, core.emap)
    dig = choice.dig
    if dig is None:
        return {"return": 0.0, "removed_l": 0.0, "overdig_l": 0.0, "load_l": 0.0, "spoil_l": 0.0, "steps": 0,
                "full_return": 0.0, "full_removed_l": 0.0, "full_steps": 0}
    clearance = float(np.min(dig.poses[:, 1] - goal_profile(goal, dig.poses[:, 0])))
    bounds = (-max(clearance, 0.0), math.inf if dig.shift_up else 0.0)
    plan = DigPlan(dig.poses, dig.phases, math.radians(goal.waist_deg), dig.volume_m3, bounds,
                   surface=rig.planner.surface(core.emap))
    sim.step_hooks.append(hook)
    try:
        rig.executor.run(plan)
    finally:
        sim.step_hooks.remove(hook)
    end = at_horizon or log
    info = end["info"]
    return {"return": end["return"], "removed_l": info["removed_l"], "overdig_l": info["overdig_l"],
            "load_l": info["load_l"], "spoil_l": info["spoil_l"], "steps": end["steps"],
            "full_return": log["return"], "full_removed_l": log["info"]["removed_l"], "full_steps": log["steps"]}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--minutes", type=float, default=35.0, help="training wall-clock budget [min]")
    parser.add_argument("--steps", type=int, default=3_000_000, help="most training steps")
    parser.add_argument("--n-envs", type=int, default=8)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default="docs/notes/2026-12-02-ppo-baseline.md")
    parser.add_argument("--quick", action="store_true", help="two evaluation seeds (a smoke run)")
    parser.add_argument("--work", default="/tmp/excavsim-ppo", help="model, statistics and curve data")
    parser.add_argument("--note-only", action="store_true",
                        help="rewrite the note from a finished run's --work directory (no training)")
    args = parser.parse_args(argv)
    work = pathlib.Path(args.work)
    if args.note_only:
        meta = json.loads((work / "run.json").read_text())
        write_note(pathlib.Path(args.out), json.loads((work / "results.json").read_text()),
                   np.loadtxt(work / "curve.csv", delimiter=",", ndmin=2), meta["steps"], meta["wall"], meta["cpu"],
                   argparse.Namespace(**meta["args"]))
        return 0

    import gymnasium as gym
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    import excavsim.envs  # noqa: F401 - registers the environments

    torch.set_num_threads(1)
    work.mkdir(parents=True, exist_ok=True)
    venv = VecNormalize(make_vec_env(ENV_ID, n_envs=args.n_envs, seed=args.seed, vec_env_cls=DummyVecEnv),
                        norm_obs=True, norm_reward=True, clip_obs=10.0)
    model = PPO("MultiInputPolicy", venv, n_steps=256, batch_size=256, n_epochs=5, learning_rate=3e-4,
                gamma=0.99, gae_lambda=0.95, policy_kwargs={"log_std_init": math.log(0.6)}, seed=args.seed,
                verbose=0, device="cpu")

    class Curve(BaseCallback):
        """Episode returns and removed soil as training goes, and the wall-clock budget."""

        def __init__(self, deadline: float):
            super().__init__()
            self.deadline = deadline
            self.rows: list[tuple[int, float, float, float]] = []

        def _on_step(self) -> bool:
            for info in self.locals["infos"]:
                if "episode" in info:
                    self.rows.append((self.num_timesteps, float(info["episode"]["r"]), float(info["removed_l"]),
                                      time.perf_counter() - t0))
            if self.n_calls % 2048 == 0 and self.rows:
                recent = self.rows[-32:]
                print(f"{self.num_timesteps:>9} steps {time.perf_counter() - t0:7.0f} s  return "
                      f"{np.mean([r[1] for r in recent]):7.2f}  removed {np.mean([r[2] for r in recent]):6.2f} L",
                      flush=True)
            return time.perf_counter() < self.deadline

    t0 = time.perf_counter()
    c0 = time.process_time()
    curve = Curve(t0 + 60 * args.minutes)
    model.learn(total_timesteps=args.steps, callback=curve)
    train_wall, train_cpu = time.perf_counter() - t0, time.process_time() - c0
    model.save(work / "ppo")
    venv.save(str(work / "vecnormalize.pkl"))
    np.savetxt(work / "curve.csv", np.array(curve.rows), delimiter=",", header="steps,return,removed_l,wall_s")
    (work / "run.json").write_text(json.dumps({"steps": model.num_timesteps, "wall": train_wall, "cpu": train_cpu,
                                               "args": {k: v for k, v in vars(args).items() if k != "note_only"}}))
    print(f"trained {model.num_timesteps} steps in {train_wall:.0f} s wall, {train_cpu:.0f} s CPU", flush=True)

    env = gym.make(ENV_ID)
    space = env.action_space
    venv.training = False

    def ppo(obs):
        action, _ = model.predict(venv.normalize_obs({k: v[None] for k, v in obs.items()}), deterministic=True)
        return action[0]

    rng = np.random.default_rng(0)

    def random_policy(_obs):
        return rng.uniform(space.low, space.high).astype(np.float32)

    results = {"ppo": [run_policy(env, ppo, s) for s in SEEDS],
               "random": [run_policy(env, random_policy, s) for s in SEEDS],
               "scripted": [run_scripted(env, s) for s in SEEDS]}
    env.close()
    (work / "results.json").write_text(json.dumps(results, indent=1))
    write_note(pathlib.Path(args.out), results, np.array(curve.rows), model.num_timesteps, train_wall, train_cpu,
               args)
    return 0


def write_note(out: pathlib.Path, results: dict, curve: np.ndarray, steps: int, wall: float, cpu: float, args) -> None:
    """The docs note: the evaluation table per policy and per seed, and the learning curve's PNG beside it."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    png = out.with_suffix(".png")
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 3.6))
    if len(curve):
        # the copies end their episodes together: average per training step, then over 3 of those
        steps_at, inverse = np.unique(curve[:, 0], return_inverse=True)
        k = min(3, len(steps_at))
        for ax, col in ((a1, 1), (a2, 2)):
            per_step = np.bincount(inverse, curve[:, col]) / np.bincount(inverse)
            ax.plot(curve[:, 0], curve[:, col], ".", ms=2, alpha=0.3, label="episodes")
            ax.plot(steps_at[k - 1:], np.convolve(per_step, np.ones(k) / k, mode="valid"), "-", label="mean")
    for a, lab in ((a1, "episode return"), (a2, "soil removed in the goal [L]")):
        a.set_xlabel("training steps")
        a.set_ylabel(lab)
        a.grid(alpha=0.3)
    fig.suptitle(f"PPO on {ENV_ID} (8 copies, 1 torch thread)")
    fig.tight_layout()
    fig.savefig(png, dpi=110)

    def row(name: str, rs: list[dict], key: str = "return", removed: str = "removed_l") -> str:
        ret = np.array([r[key] for r in rs])
        rem = np.array([r[removed] for r in rs])
        head = (f"| {name} | {ret.mean():.2f} ± {ret.std():.2f} | {rem.mean():.2f} ± {rem.std():.2f} | "
                f"{int(np.sum(rem > 0.05))} / {len(rs)} |")
        if key != "return":  # the whole dig: its end state is the executor's park, not comparable
            return head + " | | |"
        return head + (f" {np.mean([r['overdig_l'] for r in rs]):.2f} | {np.mean([r['load_l'] for r in rs]):.1f} | "
                       f"{np.mean([r['spoil_l'] for r in rs]):.1f} |")

    lines = [
        "# PPO baseline on the single-dig task (2026-12-02)",
        "",
        f"`scripts/train_ppo.py --minutes {args.minutes:g} --n-envs {args.n_envs} --seed {args.seed}` trained "
        f"Stable-Baselines3's PPO on `{ENV_ID}` for {steps:,} steps in {wall / 60:.1f} min wall "
        f"({cpu / 60:.1f} min CPU) on the shared 2-core machine (one torch thread, {args.n_envs} copies in one "
        "process, `VecNormalize`), then evaluated it, a random policy and the scripted executor on the seeds "
        f"{SEEDS[0]}-{SEEDS[-1]} (600 steps, 6 s simulated, each).",
        "",
        "| policy | return (mean ± sd) | soil removed in the goal [L] | seeds with soil removed (> 0.05 L) "
        "| over-dig [L] | in the bucket at the end [L] | to the spoil [L] |",
        "|---|---|---|---|---|---|---|",
        row("PPO (deterministic)", results["ppo"]),
        row("random", results["random"]),
        row("scripted executor, first 600 steps", results["scripted"]),
        row("scripted executor, whole dig", results["scripted"], "full_return", "full_removed_l"),
        "",
        "Per seed (return / removed litres):",
        "",
        "| seed | PPO | random | scripted (600 steps) | scripted (whole dig, steps) |",
        "|---|---|---|---|---|",
    ]
    for i, s in enumerate(SEEDS):
        p, r, c = results["ppo"][i], results["random"][i], results["scripted"][i]
        lines.append(f"| {s} | {p['return']:.2f} / {p['removed_l']:.2f} | {r['return']:.2f} / {r['removed_l']:.2f} | "
                     f"{c['return']:.2f} / {c['removed_l']:.2f} | {c['full_return']:.2f} / {c['full_removed_l']:.2f} "
                     f"({c['full_steps']}) |")
    lines += ["", "Per seed, PPO: in the bucket at the end / to the spoil / over-dig [L]: "
              + "; ".join(f"{s} {r['load_l']:.1f} / {r['spoil_l']:.1f} / {r['overdig_l']:.2f}"
                          for s, r in zip(SEEDS, results["ppo"])) + ".",
              "", f"![learning curve]({png.name})", ""]
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    sys.exit(main())
