"""Trenching's commands: ``trench`` (one episode, or a specification's), ``demo`` (one hand-picked dig),
``cycle`` (one planned dig) and ``plan`` (one dig planned on a map, outside any episode).

Added to the ``excavsim`` command by the trench plug-in (:meth:`~excavsim.tasks.trench.plugin.Trench.add_commands`);
each parses its arguments, makes one call and prints.
"""

from __future__ import annotations

import argparse
import contextlib

from excavsim.config.arguments import episode_options, float_in, name_or_path, out_dir, world_options
from excavsim.errors import ConfigError, shorten


def _cmd_demo(args: argparse.Namespace) -> int:
    from excavsim.handoff.episode import format_episode
    from excavsim.tasks.trench.demo import demo_from_configs

    print(format_episode(demo_from_configs(args.robot_config, args.scene_config, seed=args.seed, progress=print)))
    return 0


def _cmd_cycle(args: argparse.Namespace) -> int:
    from excavsim.handoff.episode import format_episode
    from excavsim.loop.scenario import EpisodeSpec, run_spec

    spec = EpisodeSpec(name="cycle", task="trench", dig_budget=1, seed=args.seed)
    print(f"excavsim cycle: park, scan, plan, dig, settle, scan: one dig of the {spec.options.goal} trench "
          f"(seed {args.seed})")
    result = run_spec(spec, progress=print, robot_path=args.robot_config, scene_path=args.scene_config)
    print(format_episode(result))
    return 0


def _cmd_trench(args: argparse.Namespace) -> int:
    from excavsim.config import parse_config
    from excavsim.loop.scenario import EpisodeSpec, load_spec, run_with_outputs

    spec = load_spec(args.spec) if args.spec else EpisodeSpec(task="trench")
    given = {"goal": args.goal, "soil": args.soil, "dig_budget": args.dig_budget, "seed": args.seed}
    if args.goal is not None and spec.task != "trench":
        raise ConfigError(f"--goal: the specification's task is {spec.task}, which has no trench goal")
    if args.record and not args.record.endswith(".rrd"):
        raise ConfigError(f"--record must name an .rrd file; given {shorten(repr(args.record), 200)}")
    spec = parse_config({**spec.model_dump(), **{k: v for k, v in given.items() if v is not None}}, EpisodeSpec,
                        source="the command line")
    live = contextlib.nullcontext(None)
    if args.live is not None:  # a viewer window that --live alone spawns ends with the command
        from excavsim.record.live import live_url

        live = live_url(args.live)
    with live as url:
        run_with_outputs(spec, robot_path=args.robot_config, scene_path=args.scene_config, record=args.record,
                         live=url, save_maps=args.save_maps, timing=args.timing,
                         command="trench --spec" if spec.task != "trench" else "trench")
    return 0


def _cmd_plan(args: argparse.Namespace) -> int:
    from excavsim.tasks.trench.plan_dig import plan_on_map

    plan_on_map(goal=args.goal, map_path=args.map, planner_config=args.planner_config, robot_config=args.robot_config,
                soil=args.soil, wrist_limit=args.wrist_limit, volume_constraint=not args.no_volume_constraint,
                figures_dir=None if args.no_figures else args.out)
    return 0


def add_commands(sub: argparse._SubParsersAction) -> None:
    """Add trenching's commands to ``sub``."""
    demo = sub.add_parser("demo", help="one hand-picked dig through the loop: scan, dig, dump, settle, scan")
    world_options(demo)
    demo.set_defaults(func=_cmd_demo)

    trench = sub.add_parser("trench", help="dig a trench: scan, plan, dig, settle until done or out of digs")
    trench.add_argument("--spec", metavar="YAML", help="an episode specification (goal, soil, seed, budget, "
                                                       "configuration overrides; e.g. configs/specs/trench_small.yaml)")
    trench.add_argument("--goal", metavar="NAME|YAML", type=name_or_path,
                        help="trench goal: a name of configs/trenches (sand, straight, small) or a YAML file "
                             "(default sand)")
    episode_options(trench)
    trench.set_defaults(func=_cmd_trench)

    cycle = sub.add_parser("cycle", help="one cycle of the loop: an episode of one dig of the default trench")
    world_options(cycle)
    cycle.set_defaults(func=_cmd_cycle)

    plan = sub.add_parser("plan", help="plan one dig of a trench on an elevation map, print it and draw figures")
    plan.add_argument("--goal", metavar="NAME|YAML", type=name_or_path,
                      help="trench goal: a name of configs/trenches or a YAML file (default straight)")
    plan.add_argument("--map", metavar="NPZ", help="elevation map written by excavsim (default: flat 0.5 m sand)")
    plan.add_argument("--planner-config", metavar="YAML", help="planner configuration (default configs/planner.yaml)")
    plan.add_argument("--robot-config", metavar="YAML", help="torque limits (default configs/robot.yaml)")
    plan.add_argument("--soil", metavar="NAME", default="testbed_sand",
                      help="soil preset of configs/soils.yaml the force predictor assumes (default testbed_sand)")
    plan.add_argument("--wrist-limit", metavar="NM", type=float_in(10, 1e6),
                      help="wrist pitch torque limit [N m] (10 to 1e6; default: the robot configuration's)")
    plan.add_argument("--out", metavar="DIR", default="runs/plan", type=out_dir,
                      help="where the figures go (default runs/plan)")
    plan.add_argument("--no-volume-constraint", action="store_true",
                      help="switch the volume constraint off: only the force constraint bounds how much a dig "
                           "sweeps (§7.2.2, Figs. 115-117; the setting of the Fig. 87 comparison)")
    plan.add_argument("--no-figures", action="store_true", help="only print the plan (pruned search, faster)")
    plan.set_defaults(func=_cmd_plan)
