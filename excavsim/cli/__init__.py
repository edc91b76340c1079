"""The ``excavsim`` command. It only parses arguments and calls the package.

One module per group of the platform's commands, each adding its own subcommands (``register``):
``episodes`` (run, replay), ``apps`` (calibrate, playback), ``studies`` (campaign, regress, experiment,
learn, figures, bench) and ``tools`` (validate, warmup); then every registered task adds its own
(:meth:`~excavsim.loop.plugin.TaskPlugin.add_commands`, e.g. trenching's ``trench``, ``demo``, ``cycle`` and
``plan``). :func:`build_parser` returns the whole parser (a docs tool can render it); :func:`main` runs it.

Errors that excavsim raises on purpose (bad configuration, unreachable poses, diverging physics)
print one clear message and exit with status 2, without a traceback.
"""

from __future__ import annotations

import argparse
import sys

from excavsim.cli import apps, episodes, studies, tools
from excavsim.config.arguments import MAX_DIG_BUDGET, MAX_SEED
from excavsim.loop import catalog
from excavsim.errors import ExcavsimError, shorten

__all__ = ["MAX_DIG_BUDGET", "MAX_SEED", "build_parser", "main"]

GROUPS = (episodes, studies, tools, apps)  # the order of the platform's commands in --help, the tasks' after


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``excavsim`` command."""
    from excavsim import __version__

    parser = argparse.ArgumentParser(prog="excavsim", description="MuJoCo testbed for robotic excavation.")
    parser.add_argument("--version", action="version", version=f"excavsim {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for group in GROUPS:
        group.register(sub)
    for plugin in catalog.plugins().values():
        plugin.add_commands(sub)
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
