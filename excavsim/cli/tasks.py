"""The task commands: ``load`` (loading from a pile, in 2-D or in MuJoCo) and ``tune`` (truck loading
by the self-tuned mass-excavation script)."""

from __future__ import annotations

import argparse
import math

from excavsim.cli.options import float_in, int_in, name_or_path, out_dir, out_file, seed_type
from excavsim.errors import ConfigError, UsageError, shorten


def _cmd_tune(args: argparse.Namespace) -> int:
    from excavsim.tasks.truck import trial as truck
    from excavsim.tasks.truck import tuning

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
        from excavsim.tasks.truck.campaign import compare

        compare(seeds=args.seeds, soils=args.soils or ([args.soil] if args.soil else None), trials=args.trials,
                out=args.out, retarget=retarget, cfg=cfg)
        return 0
    tuning.tune_and_report(args.trials, cfg, args.out, seed=args.seed, soil=args.soil, retarget=retarget,
                          record=args.record)
    return 0


def _cmd_load(args: argparse.Namespace) -> int:
    from excavsim.tasks.load import planar as ld

    cfg = ld.load_loading_config(args.config)
    if args.mujoco or args.campaign:
        return _load_mujoco(args, cfg)
    if args.record:
        raise UsageError("--record needs --mujoco (the 2-D simulation writes figures to --out)")
    if args.study:
        ld.write_study(args.config, args.out, runs=args.runs, workers=args.workers, seed=args.seed)
    else:
        ld.write_figures(cfg, args.out, machine=args.machine)
    return 0


def _load_mujoco(args: argparse.Namespace, cfg) -> int:
    """``excavsim load --mujoco`` or ``--campaign``: loading episodes in MuJoCo (excavsim.tasks.load.campaign)."""
    from excavsim.tasks.load import campaign as lm

    if args.study:
        raise UsageError("--study is the 2-D simulation's (Fig. 112); --mujoco runs single episodes")
    if args.campaign:
        if args.record or args.machine:
            raise UsageError("--campaign runs the machines and seeds its file names; --record and --machine "
                             "are single episodes' options")
        done = lm.write_campaign(args.campaign, args.out, cfg2d=cfg, mujoco_config=args.mujoco_config)
        return 0 if done else 1
    if args.record and not args.record.endswith(".rrd"):
        raise ConfigError(f"--record must name an .rrd file; given {shorten(repr(args.record), 200)}")
    done = lm.run_episodes(cfg2d=cfg, machine=args.machine, seed=args.seed, mujoco_config=args.mujoco_config,
                           record=args.record)
    return 0 if done else 1


def _cmd_truck_curve(args: argparse.Namespace) -> int:
    from excavsim.tasks.truck_loading.figure import learning_curve

    print(learning_curve(args.campaign_dir, args.out))
    print(f"wrote {args.out}")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the task commands to ``sub``."""
    load = sub.add_parser("load", help="loading from a pile in a 2-D world (§7.2.1, Figs. 108-112): front loader "
                                       "and front shovel, the action space's constraints (Figs. 28-35)")
    load.add_argument("--machine", choices=["loader", "shovel"],
                      help="one machine (default both; the loader also with the force constraint, Fig. 111)")
    load.add_argument("--study", action="store_true",
                      help="Fig. 112: efficiency against the force limit, random piles, both machines")
    load.add_argument("--runs", type=int_in(1, 1000), metavar="N", help="runs per force limit in --study "
                      "(default configs/loading.yaml's, 20)")
    load.add_argument("--workers", type=int_in(1, 64), default=1, metavar="N", help="processes for --study")
    load.add_argument("--seed", type=seed_type, default=0, metavar="N",
                      help="the first random pile's seed (--study); the episode's (--mujoco)")
    load.add_argument("--config", metavar="YAML", help="loading configuration (default configs/loading.yaml)")
    load.add_argument("--out", metavar="DIR", default="runs/load", type=out_dir,
                      help="output directory (default runs/load)")
    load.add_argument("--mujoco", action="store_true",
                      help="a loading episode in MuJoCo instead: the MJCF loader/shovel beside a pile lane, the "
                           "world's soil and scanner, the planner, a joint-space script per dig, settlement")
    load.add_argument("--mujoco-config", metavar="YAML",
                      help="with --mujoco: its configuration (default configs/loading_mujoco.yaml)")
    load.add_argument("--record", metavar="FILE.rrd", type=out_file(()),
                      help="with --mujoco and --machine: record the episode to a Rerun file")
    load.add_argument("--campaign", metavar="YAML", type=name_or_path,
                      help="MuJoCo episodes of each machine over seeds, judged together (e.g. "
                           "configs/campaigns/loading_mujoco.yaml); writes campaign.txt to --out")
    load.set_defaults(func=_cmd_load)
    tune = sub.add_parser("tune", help="truck loading by the mass-excavation script, self-tuned online by "
                          "memory-based learning (Rowe 1997 §6.2): the learning curve of Fig. 12")
    tune.add_argument("--trials", type=int_in(1, 10000), default=40, metavar="N", help="trials (default 40)")
    tune.add_argument("--seed", type=seed_type, default=0, metavar="N", help="the world's seed (default 0)")
    tune.add_argument("--config", metavar="YAML", help="truck configuration (default configs/truck.yaml)")
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
    curve = sub.add_parser("truck-curve", help="the Fig. 12-style learning curve (Rowe 1997 §6.2) of a truck_loading "
                           "campaign (configs/campaigns/excavator_truck.yaml): cost, cycle time and placement per pass")
    curve.add_argument("campaign_dir", metavar="DIR", help="the campaign's output directory (with its episodes/ folder of JSON results)")
    curve.add_argument("--out", metavar="PNG", default="runs/truck_curve.png", type=out_file((".png",)),
                       help="the figure (default runs/truck_curve.png)")
    curve.set_defaults(func=_cmd_truck_curve)
