"""The argument types and shared options of the ``excavsim`` command's subcommands, the platform's and those
the tasks contribute (:meth:`excavsim.loop.plugin.TaskPlugin.add_commands`).

Ranges and paths are checked at parse time, so a wrong value exits with status 2 before any work.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import pathlib
import tempfile

from excavsim.errors import shorten

MAX_SEED = 2**32 - 1  # seeds are unsigned 32-bit numbers, as EpisodeSpec.seed: exact in every result file
MAX_DIG_BUDGET = 1000  # EpisodeSpec.dig_budget's bound

def int_in(lo: int, hi: int):
    """An argparse type: an integer in [lo, hi]."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{shorten(repr(text))} is not an integer") from None
        if not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"{value} is out of range (allowed: {lo} to {hi})")
        return value
    return parse


def float_in(lo: float, hi: float, *, low_open: bool = False, high_open: bool = False):
    """An argparse type: a finite number in [lo, hi] (``low_open``, ``high_open``: without that end)."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{shorten(repr(text))} is not a number") from None
        if not (math.isfinite(value) and (value > lo if low_open else value >= lo)
                and (value < hi if high_open else value <= hi)):
            low, high = (">" if low_open else ">="), ("<" if high_open else "<=")
            raise argparse.ArgumentTypeError(f"{shorten(text)} is out of range (allowed: {low} {lo:g} and "
                                             f"{high} {hi:g})")
        return value
    return parse


def _check_creatable(path: pathlib.Path, shown: str) -> None:
    """Raise ArgumentTypeError unless ``path`` can be created: its nearest existing ancestor is a writable directory."""
    ancestor = path.parent
    while not ancestor.exists() and ancestor != ancestor.parent:
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise argparse.ArgumentTypeError(f"{shown}: {shorten(str(ancestor))} is a file, so {shown} cannot be "
                                         "created in it; allowed: a path under a directory")
    try:
        with tempfile.TemporaryFile(dir=ancestor):
            pass
    except OSError as exc:
        raise argparse.ArgumentTypeError(f"{shown}: cannot write in {shorten(str(ancestor))} ({exc.strerror}); "
                                         "allowed: a writable place") from None


def _path_text(text: str) -> tuple[pathlib.Path, str]:
    """``text`` as a path and as messages show it; ArgumentTypeError if it cannot be a path."""
    shown = shorten(repr(text), 200)
    if not text or "\0" in text:
        raise argparse.ArgumentTypeError(f"{shown} is not a path")
    return pathlib.Path(text), shown


def out_dir(text: str) -> str:
    """An argparse type: an output directory, existing and writable, or creatable under a writable directory."""
    path, shown = _path_text(text)
    try:
        if path.exists():
            if not path.is_dir():
                raise argparse.ArgumentTypeError(f"{shown} exists and is not a directory; allowed: a directory "
                                                 "(created if missing)")
            _check_creatable(path / "x", shown)
        else:
            _check_creatable(path, shown)
    except OSError as exc:  # e.g. a name too long
        raise argparse.ArgumentTypeError(f"{shown}: {exc.strerror or exc}") from None
    return text


def out_file(suffixes: tuple[str, ...]):
    """An argparse type: a file to write (or to read if it exists), with one of ``suffixes`` when given."""
    def parse(text: str) -> str:
        path, shown = _path_text(text)
        if suffixes and path.suffix not in suffixes:
            raise argparse.ArgumentTypeError(f"{shown}: allowed: a file name ending in {' or '.join(suffixes)}")
        try:
            if path.exists():
                if not path.is_file():
                    raise argparse.ArgumentTypeError(f"{shown} exists and is not a file; allowed: a file path")
                return text  # read or overwritten: whoever opens it says if it cannot
            _check_creatable(path, shown)
        except OSError as exc:
            raise argparse.ArgumentTypeError(f"{shown}: {exc.strerror or exc}") from None
        return text
    return parse


def name_or_path(text: str) -> str:
    """An argparse type: a preset name or a file path, at most 4096 characters and without NUL."""
    if len(text) > 4096 or "\0" in text:
        raise argparse.ArgumentTypeError(f"{shorten(repr(text))}: allowed: a name or a path of at most 4096 "
                                         "characters")
    return text


seed_type = int_in(0, MAX_SEED)
dig_budget_type = int_in(1, MAX_DIG_BUDGET)


def world_options(parser: argparse.ArgumentParser) -> None:
    """The options of every command that builds a Simulation: configurations and the episode seed."""
    parser.add_argument("--robot-config", metavar="YAML", help="servo configuration (default configs/robot.yaml)")
    parser.add_argument("--scene-config", metavar="YAML", help="scene configuration (default configs/scene.yaml)")
    parser.add_argument("--seed", type=seed_type, default=0, help=f"episode seed (soil, sensor noise, scanner drift; "
                        f"0 to {MAX_SEED})")



def episode_options(parser: argparse.ArgumentParser) -> None:
    """The options of every command that runs an episode specification (``run``, and the tasks' own such
    commands): fields of the specification, its outputs, base configurations. A task refuses the outputs it
    does not support (:attr:`excavsim.loop.plugin.TaskPlugin.outputs`)."""
    parser.add_argument("--soil", metavar="NAME", help="soil preset of configs/soils.yaml (default: the task's)")
    parser.add_argument("--dig-budget", type=dig_budget_type, metavar="N",
                        help=f"most digs to try (1 to {MAX_DIG_BUDGET}, default 20)")
    parser.add_argument("--record", metavar="FILE.rrd", type=out_file(()),
                        help="record the episode to a Rerun file (see `replay`)")
    parser.add_argument("--live", nargs="?", const="", metavar="ADDRESS",
                        help="stream the episode to a Rerun viewer as it runs: alone, spawn one (needs a display); "
                             "with PORT, HOST:PORT or rerun+http://HOST:PORT/proxy, a running viewer (`rerun`)")
    parser.add_argument("--timing", action="store_true",
                        help="print Table 7 (§7.3): the mean per-cycle perception, feasible-set, selection, set-up "
                             "and execution times beside the thesis' Sparc 10 numbers")
    parser.add_argument("--save-maps", metavar="DIR", type=out_dir,
                        help="save every scanned elevation map (for `plan --map`)")
    parser.add_argument("--robot-config", metavar="YAML", help="servo configuration (default configs/robot.yaml)")
    parser.add_argument("--scene-config", metavar="YAML", help="scene configuration (default configs/scene.yaml)")
    parser.add_argument("--seed", type=seed_type, help=f"episode seed (0 to {MAX_SEED}, default 0)")
