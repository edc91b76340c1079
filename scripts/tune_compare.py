"""Tuned against untuned truck loading over seeds, and a target moved mid-run (issue 21's campaign entry).

Kept for the commands written before ``excavsim tune --compare``, which it now calls (the campaign lives
in :mod:`excavsim.tasks.dump_trial.campaign`; Rowe 1997 §6.2, Fig. 12). The same as

    .venv/bin/excavsim tune --compare --seeds 0 1 2 --trials 40 [--soils testbed_sand sandy_loam]
        [--retarget 21] [--out runs/tune_compare]

with ``--retarget K`` here 0-based as before (the target moves before trial K + 1).
"""

from __future__ import annotations

import argparse

from excavsim import cli


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--soils", nargs="+", default=None)
    ap.add_argument("--trials", type=int, default=40)
    ap.add_argument("--retarget", type=int, default=0, metavar="K", help="move the target before trial K (0: no)")
    ap.add_argument("--r", type=float, default=1.6, help="the moved target's radius [m] (default 1.6)")
    ap.add_argument("--theta", type=float, default=45.0, help="the moved target's angle [deg] (default 45)")
    ap.add_argument("--out", default="runs/tune_compare")
    args = ap.parse_args()
    argv = ["tune", "--compare", "--trials", str(args.trials), "--seeds", *map(str, args.seeds), "--out", args.out]
    if args.soils:
        argv += ["--soils", *args.soils]
    if args.retarget:
        argv += ["--retarget", str(args.retarget + 1), "--retarget-r", str(args.r), "--retarget-theta", str(args.theta)]
    return cli.main(argv)


if __name__ == "__main__":
    raise SystemExit(main())
