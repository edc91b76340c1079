"""The pile-loading task's command ``load``: loading from a pile in 2-D (Singh 1995 §7.2.1, Figs. 108-112) or in
MuJoCo (an episode per machine, or a campaign of them). Added to the ``excavsim`` command by the task's plug-in."""

from __future__ import annotations

import argparse

from excavsim.config.arguments import int_in, name_or_path, out_dir, out_file, seed_type
from excavsim.errors import ConfigError, UsageError, shorten


def _cmd_load(args: argparse.Namespace) -> int:
    from excavsim.tasks.pile_loading import planar as ld

    cfg = ld.load_loading_config(args.config)
    if args.mujoco or args.campaign:
        return _load_mujoco(args, cfg)
    if args.record:
        raise UsageError("--record needs --mujoco (the 2-D simulation writes figures to --out)")
    if args.study:
        ld.write_study(args.config, args.out, runs=args.runs, workers=args.workers, seed=args.seed)
    else:
        ld.write_planar_figures(cfg, args.out, machine=args.machine)
    return 0


def _load_mujoco(args: argparse.Namespace, cfg) -> int:
    """``excavsim load --mujoco`` or ``--campaign``: loading episodes in MuJoCo (excavsim.tasks.pile_loading.campaign)."""
    from excavsim.tasks.pile_loading import campaign as lm

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


def add_commands(sub: argparse._SubParsersAction, machines: tuple[str, ...]) -> None:
    """Add ``load`` to ``sub``; ``machines`` are the task's."""
    load = sub.add_parser("load", help="loading from a pile in a 2-D world (§7.2.1, Figs. 108-112): front loader "
                                       "and front shovel, the action space's constraints (Figs. 28-35)")
    load.add_argument("--machine", choices=list(machines),
                      help="one machine (default both; the loader also with the force constraint, Fig. 111)")
    load.add_argument("--study", action="store_true",
                      help="Fig. 112: efficiency against the force limit, random piles, both machines")
    load.add_argument("--runs", type=int_in(1, 1000), metavar="N", help="runs per force limit in --study "
                      "(default configs/pile_loading_planar.yaml's, 20)")
    load.add_argument("--workers", type=int_in(1, 64), default=1, metavar="N", help="processes for --study")
    load.add_argument("--seed", type=seed_type, default=0, metavar="N",
                      help="the first random pile's seed (--study); the episode's (--mujoco)")
    load.add_argument("--config", metavar="YAML", help="loading configuration (default configs/pile_loading_planar.yaml)")
    load.add_argument("--out", metavar="DIR", default="runs/load", type=out_dir,
                      help="output directory (default runs/load)")
    load.add_argument("--mujoco", action="store_true",
                      help="a loading episode in MuJoCo instead: the MJCF loader/shovel beside a pile lane, the "
                           "world's soil and scanner, the planner, a joint-space script per dig, settlement")
    load.add_argument("--mujoco-config", metavar="YAML",
                      help="with --mujoco: its configuration (default configs/pile_loading.yaml)")
    load.add_argument("--record", metavar="FILE.rrd", type=out_file(()),
                      help="with --mujoco and --machine: record the episode to a Rerun file")
    load.add_argument("--campaign", metavar="YAML", type=name_or_path,
                      help="MuJoCo episodes of each machine over seeds, judged together (e.g. "
                           "configs/campaigns/pile_loading_machines.yaml); writes campaign.txt to --out")
    load.set_defaults(func=_cmd_load)
