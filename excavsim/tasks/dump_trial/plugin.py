"""The dump-trial task's plug-in: one dig-swing-dump trial of Rowe's mass-excavation script on the T3.

Rowe 1997 §6.2: the fixed dig, a scan, the script with the parameters computed for the site (§4.2),
the dump on the ground where the truck stood, a scan again; or, with ``dump_trial: {tuning: ...}``,
a run of such trials self-tuned online by memory-based learning (§5, Fig. 12). Registered by one line of
:mod:`excavsim.loop.catalog`; the rest of the task is in this folder.
"""

from __future__ import annotations

from typing import Any

from pydantic import Field

from excavsim.config import StrictModel
from excavsim.config.kinds import plain_kind
from excavsim.tasks.dump_trial.config import TruckFile
from excavsim.loop.plugin import Metric, TaskPlugin

NAME = "dump_trial"


class DumpTrialOptions(StrictModel):
    """The dump-trial task's fields of an episode specification."""

    dump_trial: dict[str, Any] = Field(default_factory=dict,
                                       description="overrides of configs/dump_trial.yaml (the target, the truck's "
                                                   "body, the cost, the tuning)")


class DumpTrial(TaskPlugin):
    """One trial of Rowe 1997's mass-excavation script on the T3 (§6.2), or a self-tuning run of them."""

    name = NAME
    title = "one dig-swing-dump trial of Rowe's mass-excavation script on the T3, or a self-tuned run (Rowe 1997 §6.2)"
    machines = ("t3",)
    options = DumpTrialOptions
    renamed_fields = {"truck": "dump_trial"}
    budget = None  # one trial is one cycle; a tuning run's trials are dump_trial.tuning.trials
    metrics = {
        "dumped_l": Metric("higher", 1.0, 0.10),       # soil the dump emptied from the bucket [l]
        "missed_l": Metric("lower", 1.0, 0.25),        # soil dumped beside the truck's bed (the spillage) [l]
        "cycle_s": Metric("lower", 0.2),               # the script's cycle time (Rowe 1997 §6.2) [s]
        "placement_error_cm": Metric("lower", 3.0),    # the pile's distance from the target [cm]
    }
    columns = (("dumped_l", "dumped l"), ("missed_l", "missed l"), ("cycle_s", "cycle s"),
               ("placement_error_cm", "place. cm"), ("first_cost", "cost 1st"), ("cost", "cost"),
               ("last_cost", "cost last 3"))
    config_kinds = (plain_kind("dump_trial", TruckFile, "a dump trial of the self-tuned script (configs/dump_trial.yaml)",
                               stem=True),)
    dig_sources = {"tuner": "excavsim.tasks.dump_trial.tuning:Tuner"}

    outputs = frozenset({"live"})

    def resolve(self, spec, *, robot_path=None, scene_path=None) -> TruckFile:
        from excavsim.tasks.dump_trial.config import load_truck_file
        from excavsim.loop.scenario import override

        super().resolve(spec, robot_path=robot_path, scene_path=scene_path)
        return override(load_truck_file(), spec.options.dump_trial, TruckFile, f"{spec.name}: dump_trial")

    def episode(self, spec, resolved, *, progress=None, observer=None):
        from excavsim.tasks.dump_trial.episode import spec_episode

        return spec_episode(spec, resolved, progress=progress, observer=observer)

    def describe(self, spec, resolved) -> str:
        tuning = resolved.tuning
        what = "one trial" if tuning is None else f"a {'tuned' if tuning.learn else 'untuned'} run of " \
                                                  f"{tuning.trials} trials"
        return f"task {self.name}, machine {spec.machine_name}, {what}, seed {spec.seed}"

    def summary(self, result) -> dict[str, Any]:
        from excavsim.tasks.dump_trial.episode import summary

        return summary(result)

    def dig_rows(self, result) -> list[dict[str, Any]]:
        from excavsim.tasks.dump_trial.episode import dig_rows

        return dig_rows(result)

    def progress_text(self, summary) -> str:
        from excavsim.tasks.dump_trial.episode import progress_text

        return progress_text(summary)

    def format_run(self, result) -> str:
        from excavsim.tasks.dump_trial.episode import format_run

        return format_run(result)

    def recorder(self, path, *, live=None):
        from excavsim.tasks.dump_trial.episode import episode_recorder

        return episode_recorder(path, live=live)

    def add_commands(self, sub) -> None:
        from excavsim.tasks.dump_trial.commands import add_commands

        add_commands(sub)
