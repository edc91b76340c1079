"""The tool commands: ``tasks`` (the registered tasks), ``validate`` (configuration files of any kind) and
``warmup`` (compile the numba kernels)."""

from __future__ import annotations

import argparse

from excavsim.validate import kinds as validate_kinds


def _cmd_warmup(args: argparse.Namespace) -> int:
    from excavsim.loop.warmup import warm_up

    warm_up()
    return 0



def _cmd_tasks(args: argparse.Namespace) -> int:
    from excavsim.loop.catalog import plugins

    for name, plugin in plugins().items():
        budget = f"; dig_budget counts {plugin.budget}" if plugin.budget else "; no dig budget"
        print(f"{name}: {plugin.title}\n  machines: {', '.join(plugin.machines)} (default {plugin.machines[0]}){budget}"
              f"\n  its fields: {', '.join(plugin.options.model_fields) or 'none'}")
    return 0


def _cmd_validate(args: argparse.Namespace) -> int:
    from excavsim.validate import validate_paths

    for line in validate_paths(args.file, kind=args.kind):
        print(line)
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the tool commands to ``sub``."""
    warm = sub.add_parser("warmup", help="compile every numba kernel into the cache (make runs it after installing), "
                                          "so the first run starts warm")
    warm.set_defaults(func=_cmd_warmup)

    tasks = sub.add_parser("tasks", help="list the registered tasks: what each is, its machines and its own "
                                         "fields of an episode specification")
    tasks.set_defaults(func=_cmd_tasks)

    validate = sub.add_parser("validate", help="check configuration files of any kind and report every problem")
    validate.add_argument("file", nargs="+", metavar="FILE",
                          help="a configuration file (YAML; the regression baseline: JSON) or a directory (every "
                               "such file under it); its kind is told from its place in configs/ or its fields "
                               "(the older form KIND FILE still works)")
    validate.add_argument("--kind", choices=list(validate_kinds()),
                          help="what the files configure (spec: an episode specification, resolved as its task "
                               "resolves it; campaign and experiment: every episode they make; the tasks add their "
                               "own kinds; default: told from each file)")
    validate.set_defaults(func=_cmd_validate)
