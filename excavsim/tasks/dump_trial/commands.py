"""The dump-trial task's command ``tune``: Rowe's mass-excavation script self-tuned online over trials
(Rowe 1997 §6.2, Fig. 12), or the tuned-vs-untuned campaign. Added to the ``excavsim`` command by the task's
plug-in."""

from __future__ import annotations

import argparse
import math

from excavsim.config.arguments import float_in, int_in, out_dir, out_file, seed_type
from excavsim.errors import ConfigError, UsageError


def _cmd_tune(args: argparse.Namespace) -> int:
    from excavsim.tasks.dump_trial import trial as truck
    from excavsim.tasks.dump_trial import tuning

    cfg = truck.load_truck_config(args.config)
    retarget = None
    if args.retarget is not None:
        if not 1 <= args.retarget <= args.trials:
            raise ConfigError(f"--retarget {args.retarget}: the trial before which the target moves; allowed: 1 to "
                              f"--trials ({args.trials})")
        retarget = (args.retarget - 1, args.retarget_r, math.radians(args.retarget_theta))
    if args.compare:
        if args.record:
            raise UsageError("--record writes one run: leave it out with --compare")
        from excavsim.tasks.dump_trial.campaign import compare_tuning

        compare_tuning(seeds=args.seeds, soils=args.soils or ([args.soil] if args.soil else None), trials=args.trials,
                       out=args.out, retarget=retarget, cfg=cfg)
        return 0
    tuning.tune_and_report(args.trials, cfg, args.out, seed=args.seed, soil=args.soil, retarget=retarget,
                          record=args.record)
    return 0


def add_commands(sub: argparse._SubParsersAction) -> None:
    """Add ``tune`` to ``sub``."""
    tune = sub.add_parser("tune", help="truck loading by the mass-excavation script, self-tuned online by "
                          "memory-based learning (Rowe 1997 §6.2): the learning curve of Fig. 12")
    tune.add_argument("--trials", type=int_in(1, 10000), default=40, metavar="N", help="trials (default 40)")
    tune.add_argument("--seed", type=seed_type, default=0, metavar="N", help="the world's seed (default 0)")
    tune.add_argument("--config", metavar="YAML", help="truck configuration (default configs/dump_trial.yaml)")
    tune.add_argument("--out", metavar="DIR", default="runs/tune", type=out_dir,
                      help="output directory (default runs/tune)")
    tune.add_argument("--soil", metavar="NAME", help="soil preset of configs/soils.yaml (default the scene's)")
    tune.add_argument("--record", metavar="FILE.rrd", type=out_file((".rrd",)),
                      help="record the trials to Rerun (the target, the pile, the script's phases)")
    tune.add_argument("--retarget", type=int_in(1, 10000), metavar="K",
                      help="move the dump target before trial K (1-based)")
    tune.add_argument("--retarget-r", type=float_in(0.5, 3.0), default=1.6, metavar="M",
                      help="the moved target's radius [m] (default 1.6)")
    tune.add_argument("--retarget-theta", type=float_in(-90.0, 90.0), default=45.0, metavar="DEG",
                      help="the moved target's angle [deg] (default 45)")
    tune.add_argument("--compare", action="store_true",
                      help="the campaign: tuned vs untuned (and the moved target with --retarget) over --seeds and "
                           "--soils; writes truck_campaign.csv and .txt to --out")
    tune.add_argument("--seeds", type=seed_type, nargs="+", default=[0, 1, 2], metavar="N",
                      help="seeds of --compare (default 0 1 2)")
    tune.add_argument("--soils", nargs="+", metavar="NAME", help="soil presets of --compare (default the scene's)")
    tune.set_defaults(func=_cmd_tune)
