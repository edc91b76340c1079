"""The ``excavsim`` command. It only parses arguments and calls the package.

One module per group of commands, each adding its own subcommands (``register``): ``episodes``
(demo, cycle, trench, replay), ``tasks`` (load, tune), ``apps`` (calibrate, playback), ``studies``
(campaign, regress, experiment, learn, figures, bench) and ``tools`` (validate, plan, warmup).
:func:`build_parser` returns the whole parser (a docs tool can render it); :func:`main` runs it.

Errors that excavsim raises on purpose (bad configuration, unreachable poses, diverging physics)
print one clear message and exit with status 2, without a traceback.
"""

from __future__ import annotations

import argparse
import sys

from excavsim.cli import apps, episodes, studies, tasks, tools
from excavsim.cli.options import MAX_DIG_BUDGET, MAX_SEED
from excavsim.errors import ExcavsimError, shorten

__all__ = ["MAX_DIG_BUDGET", "MAX_SEED", "build_parser", "main"]

GROUPS = (episodes, studies, tools, apps, tasks)  # the order of the commands in --help


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``excavsim`` command."""
    from excavsim import __version__

    parser = argparse.ArgumentParser(prog="excavsim", description="MuJoCo testbed for robotic trenching.")
    parser.add_argument("--version", action="version", version=f"excavsim {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for group in GROUPS:
        group.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the console script; returns the exit status."""
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as exc:  # argparse has printed its message (status 2) or the help (status 0)
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
    try:
        return args.func(args)
    except ExcavsimError as exc:  # every line cut short: a message never repeats a huge input whole
        text = "\n".join(shorten(line, 400) for line in str(exc).splitlines()[:50])
        print(f"excavsim: error: {text}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("excavsim: interrupted", file=sys.stderr)
        return 130
