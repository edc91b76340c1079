"""The truck-loading task's command ``truck-curve``: the Fig. 12-style learning curve (Rowe 1997 §6.2) of a
campaign's passes. Added to the ``excavsim`` command by the task's plug-in."""

from __future__ import annotations

import argparse

from excavsim.config.arguments import out_file


def _cmd_truck_curve(args: argparse.Namespace) -> int:
    from excavsim.tasks.truck_loading.figure import learning_curve

    print(learning_curve(args.campaign_dir, args.out))
    print(f"wrote {args.out}")
    return 0


def add_commands(sub: argparse._SubParsersAction) -> None:
    """Add ``truck-curve`` to ``sub``."""
    curve = sub.add_parser("truck-curve", help="the Fig. 12-style learning curve (Rowe 1997 §6.2) of a truck_loading "
                           "campaign (configs/campaigns/excavator_truck.yaml): cost, cycle time and placement per pass")
    curve.add_argument("campaign_dir", metavar="DIR", help="the campaign's output directory (with its episodes/ "
                                                           "folder of JSON results)")
    curve.add_argument("--out", metavar="PNG", default="runs/truck_curve.png", type=out_file((".png",)),
                       help="the figure (default runs/truck_curve.png)")
    curve.set_defaults(func=_cmd_truck_curve)
