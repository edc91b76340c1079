"""Tuned against untuned truck loading over seeds, and a target moved mid-run (issue 21's campaign entry).

001_0de172b0d6b3614b.txt §6.2 (Fig. 12). For each seed: ``excavsim tune``'s online learner
(:func:`excavsim.loop.truck.tune`) and the untuned baseline (every trial from the computed parameters plus
the same small noise, ``learn=False``); with ``--retarget K`` also a tuned run whose target moves before
trial K (to ``--r`` m, ``--theta`` deg): does it re-learn? Prints the mean cost, time and squared placement
error of the first and last 6 trials (and of the 6 trials after the move), and writes one CSV row per trial.

    .venv/bin/python scripts/tune_compare.py --seeds 0 1 2 --trials 40 [--retarget 20] [--out runs/tune_compare]
"""

from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path

import numpy as np

from excavsim.loop import truck


def summary(trials: list[truck.Trial], cfg: truck.TruckConfig, sl: slice) -> tuple[float, float, float, int]:
    part = trials[sl]
    return (float(np.mean([truck.trial_cost(t, cfg) for t in part])), float(np.mean([t.time_s for t in part])),
            float(np.mean([truck.placement_error2(t, cfg) for t in part])), sum(t.failed for t in part))


def fmt(s: tuple[float, float, float, int]) -> str:
    return f"cost {s[0]:7.2f}  time {s[1]:.2f} s  err2 {s[2]:.4f} m^2  failed {s[3]}"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--trials", type=int, default=40)
    ap.add_argument("--retarget", type=int, default=0, metavar="K", help="move the target before trial K (0: no)")
    ap.add_argument("--r", type=float, default=1.6, help="the moved target's radius [m] (default 1.6)")
    ap.add_argument("--theta", type=float, default=45.0, help="the moved target's angle [deg] (default 45)")
    ap.add_argument("--out", default="runs/tune_compare")
    args = ap.parse_args()
    cfg = truck.load_truck_config()
    k = cfg.initial_trials
    rows = []
    for seed in args.seeds:
        runs = {"tuned": truck.tune(args.trials, cfg, seed=seed),
                "untuned": truck.tune(args.trials, cfg, seed=seed, learn=False)}
        if args.retarget:
            runs["retarget"] = truck.tune(args.trials, cfg, seed=seed,
                                          retarget=(args.retarget, args.r, math.radians(args.theta)))
        for name, trials in runs.items():
            print(f"seed {seed} {name:9s} first {k}: {fmt(summary(trials, cfg, slice(0, k)))}")
            if name == "retarget":
                after = slice(args.retarget, args.retarget + k)
                print(f"seed {seed} {name:9s} after move: {fmt(summary(trials, cfg, after))}")
            print(f"seed {seed} {name:9s} last {k}:  {fmt(summary(trials, cfg, slice(-k, None)))}", flush=True)
            for t in trials:
                rows.append({"seed": seed, "run": name, "trial": t.index + 1, "source": t.source,
                             "cost": truck.trial_cost(t, cfg), "time_s": t.time_s,
                             "sq_error_m2": truck.placement_error2(t, cfg), "failed": int(t.failed),
                             "target_r_m": truck.trial_objective(t, cfg).r_d,
                             "target_theta_deg": math.degrees(truck.trial_objective(t, cfg).theta_d)})
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with (out / "tune_compare.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print(f"wrote {out / 'tune_compare.csv'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
