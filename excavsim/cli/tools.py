"""The tool commands: ``validate`` (a configuration file), ``plan`` (one dig on a map) and ``warmup``
(compile the numba kernels)."""

from __future__ import annotations

import argparse

from excavsim.cli.options import float_in, name_or_path, out_dir
from excavsim.validate import KINDS as VALIDATE_KINDS


def _cmd_warmup(args: argparse.Namespace) -> int:
    from excavsim.loop.warmup import warm_up

    warm_up()
    return 0



def _cmd_validate(args: argparse.Namespace) -> int:
    from excavsim.validate import validate_paths

    for line in validate_paths(args.file, kind=args.kind):
        print(line)
    return 0


def _cmd_plan(args: argparse.Namespace) -> int:
    from excavsim.tasks.trench.plan_dig import plan_on_map

    plan_on_map(goal=args.goal, map_path=args.map, planner_config=args.planner_config, robot_config=args.robot_config,
                soil=args.soil, wrist_limit=args.wrist_limit, volume_constraint=not args.no_volume_constraint,
                figures_dir=None if args.no_figures else args.out)
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the tool commands to ``sub``."""
    warm = sub.add_parser("warmup", help="compile every numba kernel into the cache (make runs it after installing), "
                                          "so the first run starts warm")
    warm.set_defaults(func=_cmd_warmup)

    validate = sub.add_parser("validate", help="check configuration files of any kind and report every problem")
    validate.add_argument("file", nargs="+", metavar="FILE",
                          help="a configuration file (YAML; the regression baseline: JSON) or a directory (every "
                               "such file under it); its kind is told from its place in configs/ or its fields "
                               "(the older form KIND FILE still works)")
    validate.add_argument("--kind", choices=list(VALIDATE_KINDS),
                          help="what the files configure (goal: a trench goal, checked against configs/scene.yaml; "
                               "spec: an episode specification with its overrides and goal; campaign and "
                               "experiment: every episode they make; default: told from each file)")
    validate.set_defaults(func=_cmd_validate)

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
