"""The ``excavsim`` command. It only parses arguments and calls the package.

Errors that excavsim raises on purpose (bad configuration, unreachable poses, diverging physics)
print one clear message and exit with status 2, without a traceback.
"""

from __future__ import annotations

import argparse
import sys

from excavsim.errors import ExcavsimError


def _cmd_demo(args: argparse.Namespace) -> int:
    from excavsim.config import load_robot_config, load_scene_config
    from excavsim.loop.demo import format_summary, run_demo
    from excavsim.world.simulation import Simulation

    robot = load_robot_config(args.robot_config)
    scene = load_scene_config(args.scene_config)
    print(f"excavsim demo: T3 arm digs one hand-written dig into {scene.soil}, dumps to spoil, the soil settles")
    sim = Simulation(robot, scene, seed=args.seed)
    summary = run_demo(sim, progress=print)
    print(format_summary(summary))
    return 0


def _cmd_bench(args: argparse.Namespace) -> int:
    from excavsim.bench import BENCHMARKS, run_benchmarks

    unknown = [n for n in args.names if n not in BENCHMARKS]
    if unknown:
        raise ExcavsimError(f"unknown benchmark(s) {unknown}; available: {sorted(BENCHMARKS)}")
    run_benchmarks(args.names or None)
    return 0


def _cmd_validate(args: argparse.Namespace) -> int:
    from excavsim.config import RobotConfig, SceneConfig, SensingConfig, SoilsFile, load_config

    kinds = {"robot": RobotConfig, "scene": SceneConfig, "soils": SoilsFile, "sensing": SensingConfig}
    load_config(args.file, kinds[args.kind])
    print(f"{args.file}: valid {kinds[args.kind].__name__}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``excavsim`` command."""
    parser = argparse.ArgumentParser(prog="excavsim", description="MuJoCo testbed for robotic trenching.")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    demo = sub.add_parser("demo", help="one scripted dig into the soil, a dump, and settlement")
    demo.add_argument("--robot-config", metavar="YAML", help="servo configuration (default configs/robot.yaml)")
    demo.add_argument("--scene-config", metavar="YAML", help="scene configuration (default configs/scene.yaml)")
    demo.add_argument("--seed", type=int, default=0, help="episode seed (soil heterogeneity, sensor noise)")
    demo.set_defaults(func=_cmd_demo)

    bench = sub.add_parser("bench", help="run benchmarks and print one table of numbers and ratios")
    bench.add_argument("names", nargs="*", metavar="NAME", help="benchmarks to run (default: all)")
    bench.set_defaults(func=_cmd_bench)

    validate = sub.add_parser("validate", help="check a configuration file and report every problem")
    validate.add_argument("kind", choices=["robot", "scene", "soils", "sensing"], help="what the file configures")
    validate.add_argument("file", help="the YAML file")
    validate.set_defaults(func=_cmd_validate)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the console script; returns the exit status."""
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except ExcavsimError as exc:
        print(f"excavsim: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("excavsim: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
