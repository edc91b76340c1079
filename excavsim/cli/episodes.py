"""The episode commands of every task: ``run`` (a specification's episode, whatever its task) and ``replay``
(a recorded episode in the Rerun viewer). The tasks add their own commands (:mod:`excavsim.loop.catalog`)."""

from __future__ import annotations

import argparse
import math
import pathlib

from excavsim.cli.live import live_stream
from excavsim.config.arguments import episode_options, out_file
from excavsim.errors import ConfigError, UsageError, shorten


def _cmd_run(args: argparse.Namespace) -> int:
    """``excavsim run SPEC``: the specification's episode, whatever its task, with the outputs asked for."""
    from excavsim.config import parse_config
    from excavsim.loop.scenario import EpisodeSpec, load_spec, run_with_outputs

    spec = load_spec(args.spec)
    given = {"soil": args.soil, "dig_budget": args.dig_budget, "seed": args.seed}
    if args.record and not args.record.endswith(".rrd"):
        raise ConfigError(f"--record must name an .rrd file; given {shorten(repr(args.record), 200)}")
    spec = parse_config({**spec.model_dump(), **{k: v for k, v in given.items() if v is not None}}, EpisodeSpec,
                        source="the command line")
    with live_stream(args.live) as live:  # a viewer window that --live spawns ends with the command
        run_with_outputs(spec, robot_path=args.robot_config, scene_path=args.scene_config, record=args.record,
                         live=live, save_maps=args.save_maps, timing=args.timing, command="run")
    return 0


def _sim_time(text: str) -> float | None:
    """An argparse type of ``replay --time``: simulated seconds (a number >= 0), or ``end``."""
    if text.strip().lower() == "end":
        return None
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{shorten(repr(text))} is not a time; allowed: seconds of simulated "
                                         "time (>= 0) or 'end'") from None
    if not (math.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"{shorten(text)} is out of range (allowed: >= 0 s, or 'end')")
    return value


def _window_size(text: str) -> tuple[int, int]:
    """An argparse type of ``replay --size``: WIDTHxHEIGHT in logical points, each 320 to 7680."""
    import re

    m = re.fullmatch(r"\s*(\d{1,5})\s*[xX]\s*(\d{1,5})\s*", text)
    if not m:
        raise argparse.ArgumentTypeError(f"{shorten(repr(text))} is not a size; allowed: WIDTHxHEIGHT, e.g. 1600x1000")
    w, h = int(m.group(1)), int(m.group(2))
    if not (320 <= w <= 7680 and 240 <= h <= 4320):
        raise argparse.ArgumentTypeError(f"{w}x{h} is out of range (allowed: 320 to 7680 wide, 240 to 4320 high)")
    return w, h


def _screenshot_paths(png: str, times: list[float | None]) -> list[tuple[float | None, str]]:
    """The PNG of each ``--time``: ``png`` itself for one time, else ``png``'s stem with the time added."""
    if len(times) == 1:
        return [(times[0], png)]
    p = pathlib.Path(png)
    return [(t, str(p.with_name(f"{p.stem}_{'end' if t is None else f'{t:g}s'}{p.suffix}"))) for t in times]


def _cmd_replay(args: argparse.Namespace) -> int:
    from excavsim.record.replay import check_recording, replay

    if args.screenshot is None and (args.time is not None or args.size is not None):
        raise UsageError("--time and --size go with --screenshot PNG (they choose what the headless viewer renders)")
    check_recording(args.file)
    if args.screenshot is not None:
        from excavsim.record.replay import screenshots

        shots = _screenshot_paths(args.screenshot, args.time or [None])
        if args.dry_run:
            print(f"would render {args.file} headless at {', '.join(f'{t}' for t, _ in shots)} to "
                  f"{', '.join(p for _, p in shots)}")
            return 0
        screenshots(args.file, shots, size=args.size or (1600, 1000))
        return 0
    replay(args.file, dry_run=args.dry_run)
    return 0



def register(sub: argparse._SubParsersAction) -> None:
    """Add the episode commands to ``sub``."""
    run = sub.add_parser("run", help="run an episode specification of any task (`excavsim tasks` lists them)")
    run.add_argument("spec", metavar="SPEC.yaml", help="an episode specification: its task, machine, soil, seed, "
                                                      "budget and configuration overrides (e.g. configs/specs/"
                                                      "trench_small.yaml)")
    episode_options(run)
    run.set_defaults(func=_cmd_run)

    replay = sub.add_parser("replay", help="open a recorded episode (.rrd) in the Rerun viewer")
    replay.add_argument("file", metavar="FILE.rrd",
                        help="a recording written by `excavsim trench --record` (checked with `rerun rrd verify`)")
    replay.add_argument("--dry-run", action="store_true", help="only print the viewer command")
    replay.add_argument("--screenshot", metavar="PNG", type=out_file((".png",)),
                        help="render headless instead of opening a window, and write PNG (needs Vulkan: a GPU "
                             "driver or, without one, Debian's mesa-vulkan-drivers)")
    replay.add_argument("--time", nargs="+", type=_sim_time, metavar="T",
                        help="simulated times [s] (or 'end', the default) of the screenshots; with several, "
                             "PNG's name gets the time added (shot_20s.png)")
    replay.add_argument("--size", type=_window_size, metavar="WxH",
                        help="the headless viewer's size in points (default 1600x1000)")
    replay.set_defaults(func=_cmd_replay)


