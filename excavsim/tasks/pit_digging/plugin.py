"""The pit-digging task's plug-in: what the platform, the CLI, ``validate`` and the studies know of it.

The T3 digs a rectangular pit in its soil box, lane by lane, with the trench planner (Singh 1995 ch. 6)
planning each dig in one lane's arm plane. Registered by one line of :mod:`excavsim.loop.catalog`;
everything else of the task is in this folder, and the docs' "Write your own task" page walks through it.
This module stays light to import: the hooks import the task's heavy modules when they are called.
"""

from __future__ import annotations

import importlib
from typing import Any

from pydantic import Field

from excavsim.config import StrictModel, load_config
from excavsim.handoff.episode import format_episode
from excavsim.loop.catalog import summary_number
from excavsim.loop.plugin import EnvEntry, Metric, TaskPlugin
from excavsim.tasks.pit_digging.goal import PitGoal

NAME = "pit_digging"
PIT_DIG_ENV_ID = "excavsim/PitDig-v0"
"""The task's Gymnasium environment (:class:`~excavsim.tasks.pit_digging.env.PitDigEnv`)."""


def _task():
    """The task's episode module (:mod:`~excavsim.tasks.pit_digging.task`), imported when a hook first needs it."""
    return importlib.import_module("excavsim.tasks.pit_digging.task")


class PitOptions(StrictModel):
    """The pit-digging task's fields of an episode specification (beside the common ones)."""

    pit: str | PitGoal = Field(default_factory=PitGoal, description="the pit inline, or a YAML file of its fields")
    done_fraction: float = Field(default=0.95, gt=0, le=1, description="share of the pit's soil that counts as done")
    tolerance_m: float = Field(default=0.03, gt=0, le=1, description="no map sample may stay this far above the goal")
    scene: dict[str, Any] = Field(default_factory=dict, description="overrides of configs/scene.yaml")
    planner: dict[str, Any] = Field(default_factory=dict, description="overrides of configs/planner.yaml")
    executor: dict[str, Any] = Field(default_factory=dict, description="overrides of configs/executor.yaml")
    sensing: dict[str, Any] = Field(default_factory=dict, description="overrides of configs/sensing.yaml")


class PitDigging(TaskPlugin):
    """A rectangular pit dug by the T3 as radial lanes, each dig planned by the trench planner in its lane."""

    name = NAME
    title = "dig a rectangular pit with the T3, lane by lane, each dig planned by the trench planner (Singh 1995 ch. 6)"
    machines = ("t3",)
    options = PitOptions
    budget = "digs"
    metrics = {
        "removed_fraction": Metric("higher", 0.05),    # share of the pit's soil removed (true terrain)
        "digs": Metric("lower", 1.0),                  # digs to the end
        "dug_l_per_dig": Metric("higher", 1.0, 0.10),  # soil in the bucket per dig [l]
        "overdig_max_cm": Metric("lower", 1.0),        # deepest cut below the pit's goal [cm]
        "underdig_rms_cm": Metric("lower", 0.5),       # soil left above the goal, RMS over the pit [cm]
    }
    columns = (("lanes_dug", "lanes"), ("overdig_max_cm", "over cm"), ("underdig_rms_cm", "under cm"))
    environments = (EnvEntry(PIT_DIG_ENV_ID, "excavsim.tasks.pit_digging.env:PitDigEnv"),)
    dig_sources = {"lanes": "excavsim.tasks.pit_digging.digs:LaneDigs"}

    def resolve(self, spec, *, robot_path=None, scene_path=None):
        super().resolve(spec, robot_path=robot_path, scene_path=scene_path)  # refuses base files: it has none
        return _task().resolve(spec)

    def episode(self, spec, resolved, *, progress=None, observer=None):
        return _task().spec_episode(spec, resolved, progress=progress, observer=observer)

    def as_mapping(self, field, value, data):
        if field != "pit" or not isinstance(value, str):
            return None
        return load_config(value, PitGoal).model_dump()  # a pit file, so that a campaign can vary pit.depth_m

    def describe(self, spec, resolved) -> str:
        p = resolved.pit
        return (f"pit {p.name}, {p.far_x_m - p.near_x_m:.2f} x {p.y_max_m - p.y_min_m:.2f} m, {p.depth_m:.2f} m deep, "
                f"in {len(resolved.lanes)} lanes, {spec.dig_budget} digs at most, soil {resolved.scene.soil}, "
                f"seed {spec.seed}")

    def summary(self, result) -> dict[str, Any]:
        return _task().summary(result)

    def dig_rows(self, result) -> list[dict[str, Any]]:
        return _task().dig_rows(result)

    def progress_text(self, summary) -> str:
        num = summary_number(summary)
        return f"{num('digs')} digs in {num('lanes_dug')} lanes, {num('removed_fraction', 100)} % removed"

    def format_run(self, result) -> str:
        return format_episode(result)  # the trench's table: the digs' actions, litres and outcomes

    def recorder(self, path, *, live=None):
        from excavsim.tasks.pit_digging.recording import PitRecorder

        return PitRecorder(path, live=live)
