"""The truck-loading task's plug-in: a truck loaded to full by the 25 t excavator, pass after pass.

Rowe 1997 §4, §6: AutoDig, the coupled loading script over the truck's side, the deposit aimed in the bed,
the script's parameters self-tuned online. Registered by one line of :mod:`excavsim.loop.catalog`; the
rest of the task is in this folder.
"""

from __future__ import annotations

from typing import Any

from pydantic import Field

from excavsim.config import StrictModel
from excavsim.config.kinds import plain_kind
from excavsim.tasks.truck_loading.config import TruckLoadingFile
from excavsim.loop.plugin import Metric, TaskPlugin

NAME = "truck_loading"


class TruckLoadingOptions(StrictModel):
    """The truck-loading task's fields of an episode specification."""

    truck_loading: dict[str, Any] = Field(default_factory=dict,
                                          description="overrides of configs/truck_loading.yaml (the truck, AutoDig, "
                                                      "the dig sites, the script, the tuning)")


class TruckLoading(TaskPlugin):
    """A truck loaded to full, pass after pass, by the 25 t excavator (Rowe 1997 §4, §6)."""

    name = NAME
    title = "load a truck to full, pass after pass, with the 25 t excavator and Rowe's self-tuned script (Rowe 1997 §4, §6)"
    machines = ("excavator_25t",)
    options = TruckLoadingOptions
    budget = "passes"
    metrics = {
        "digs": Metric("lower", 1.0),                  # passes
        "truck_t": Metric("higher", 0.3, 0.05),        # soil in the truck [t]
        "spill_l": Metric("lower", 30.0, 0.25),        # soil that left the bucket and missed the bed [l]
        "cycle_s": Metric("lower", 0.2),               # per bucket [s]
        "placement_error_cm": Metric("lower", 3.0),    # from the aim in the bed [cm]
    }
    columns = (("cycle_s", "cycle s"), ("placement_error_cm", "place. cm"), ("first_cost", "cost 1st"),
               ("cost", "cost"), ("truck_t", "truck t"), ("spill_l", "spill l"), ("truck_s", "truck s"),
               ("last_cost", "cost last 3"))
    config_kinds = (plain_kind("truck_loading", TruckLoadingFile,
                               "a truck loaded to full by the 25 t excavator (configs/truck_loading.yaml)", stem=True),)

    outputs = frozenset({"live"})

    def resolve(self, spec, *, robot_path=None, scene_path=None) -> TruckLoadingFile:
        from excavsim.tasks.truck_loading.config import load_truck_loading_file
        from excavsim.loop.scenario import override

        super().resolve(spec, robot_path=robot_path, scene_path=scene_path)
        return override(load_truck_loading_file(), spec.options.truck_loading, TruckLoadingFile,
                        f"{spec.name}: truck_loading")

    def episode(self, spec, resolved, *, progress=None, observer=None):
        from excavsim.loop.episode import Episode
        from excavsim.tasks.truck_loading.task import TruckLoadingTask

        return Episode(TruckLoadingTask(spec.machine_name, cfg=resolved, soil=spec.soil), dig_budget=spec.dig_budget,
                       progress=progress, observer=observer)

    def summary(self, result) -> dict[str, Any]:
        from excavsim.tasks.truck_loading.task import summary

        return summary(result)

    def dig_rows(self, result) -> list[dict[str, Any]]:
        from excavsim.tasks.truck_loading.task import dig_rows

        return dig_rows(result)

    def progress_text(self, summary) -> str:
        from excavsim.loop.catalog import summary_number

        num = summary_number(summary)
        return (f"{num('digs')} passes, {num('truck_t', fmt='.1f')} t in the truck, {num('spill_l')} l spilled, "
                f"{num('cycle_s', fmt='.1f')} s a bucket")

    def format_run(self, result) -> str:
        from excavsim.tasks.truck_loading.task import format_run

        return format_run(result)

    def recorder(self, path, *, live=None):
        from excavsim.tasks.truck_loading.task import episode_recorder

        return episode_recorder(path, live=live)

    def add_commands(self, sub) -> None:
        from excavsim.tasks.truck_loading.commands import add_commands

        add_commands(sub)
