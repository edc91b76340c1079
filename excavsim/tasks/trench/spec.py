"""Trenching's fields of an episode specification, and the configurations they resolve to.

:class:`TrenchOptions` is the trench task's own part of an
:class:`~excavsim.loop.scenario.EpisodeSpec` (the goal, the stopping rules, the overrides of the
robot, scene, planner, executor and sensing files, the memory of failed digs and the force
predictor); :class:`TrenchResolved` is what they stand for with every override applied, and
:func:`resolve_goal` finds a goal by name in the machine's folder of ``configs/trenches/``.
"""

from __future__ import annotations

import pathlib
import re
from typing import Any

from pydantic import Field, field_validator

from excavsim.config import (ConfigError, ExecutorConfig, PlannerConfig, RobotConfig, SceneConfig, SensingConfig,
                             StrictModel, TrenchGoal, load_executor_config, load_planner_config, load_robot_config,
                             load_scene_config, load_sensing_config, load_trench_goal)
from excavsim.tasks.trench.machines import load_machine_config, machine_box, machine_scene, machine_trenches_dir
from excavsim.config.semantic import check_goal
from excavsim.errors import shorten
from excavsim.loop.scenario import override

T3 = "t3"  # the testbed arm: its goals lie in configs/trenches/ itself, its servos in configs/robot.yaml


class TrenchOptions(StrictModel):
    """The trench task's fields of an episode specification."""

    goal: str | TrenchGoal = Field(
        default="sand", description="a trench of configs/trenches (by name), a YAML path, or the goal inline")
    done_fraction: float | None = Field(default=0.95, gt=0, le=1,
                                        description="goal volume fraction that counts as done (null: never done "
                                                    "early, every dig of the budget is dug: digging for data)")
    tolerance_m: float = Field(default=0.03, gt=0, le=1, description="no map cell may stay this far above the goal")
    robot: dict[str, Any] = Field(default_factory=dict, description="overrides of configs/robot.yaml")
    scene: dict[str, Any] = Field(default_factory=dict, description="overrides of configs/scene.yaml")
    planner: dict[str, Any] = Field(default_factory=dict, description="overrides of configs/planner.yaml")
    executor: dict[str, Any] = Field(default_factory=dict, description="overrides of configs/executor.yaml")
    sensing: dict[str, Any] = Field(default_factory=dict, description="overrides of configs/sensing.yaml")
    memory: bool = Field(
        default=True, description="remember failed digs and where digs found no soil, and plan around them "
                                  "(excavsim.planning.experience); false plans every dig afresh, as the thesis")
    predictor: str = Field(
        default="wedge", description="the planner's force predictor: wedge (nominal, eq. 8) or a learning method "
                                     "of excavsim.learning.predictors.METHODS, learned online from this episode's digs")

    @field_validator("predictor")
    @classmethod
    def _known_predictor(cls, v: str) -> str:
        if v != "wedge":
            from excavsim.learning.predictors import METHODS

            if v not in METHODS:
                raise ConfigError(f"unknown predictor {v!r}; allowed: wedge, {', '.join(METHODS)}")
        return v


def resolve_goal(goal: str | TrenchGoal, machine: str = T3) -> TrenchGoal:
    """A goal given by name (the T3's configs/trenches/NAME.yaml, another machine's
    configs/trenches/<machine>/NAME.yaml, in its own pit's coordinates), by path, or inline."""
    if isinstance(goal, TrenchGoal):
        return goal
    path = pathlib.Path(goal)
    if path.suffix not in (".yaml", ".yml"):
        folder = machine_trenches_dir(machine)
        path = folder / f"{goal}.yaml"
        if not re.fullmatch(r"[A-Za-z0-9_.-]{1,100}", goal) or not path.is_file():
            names = sorted(p.stem for p in folder.glob("*.yaml"))
            of = "" if machine == T3 else f" of machine {machine}"
            raise ConfigError(f"unknown trench goal{of} {shorten(repr(goal))}; give a YAML path or one of: "
                              f"{', '.join(names)}")
    return load_trench_goal(path)


class TrenchResolved:
    """The configurations a trench specification stands for, with every override applied: the machine, the
    goal (in the machine's pit) and the robot, scene, planner, executor and sensing configurations (the
    machine's own overrides first, ``configs/machines/<machine>.yaml``, then the spec's).

    Args:
        spec: the specification (its ``options`` a :class:`TrenchOptions`).
        robot_path, scene_path: base files instead of ``configs/robot.yaml`` and ``configs/scene.yaml``.

    Raises:
        ConfigError: naming the file or field and what is allowed.
    """

    def __init__(self, spec, *, robot_path: str | pathlib.Path | None = None,
                 scene_path: str | pathlib.Path | None = None):
        self.spec = spec
        o: TrenchOptions = spec.options
        machine = self.machine = spec.machine_name
        if machine != T3 and o.robot:
            raise ConfigError(f"{spec.name}: robot: overrides configs/robot.yaml, the T3's servos; machine {machine} "
                              f"drives its joints through its cylinders (models/{machine})")
        self.goal: TrenchGoal = resolve_goal(o.goal, machine)
        self.robot: RobotConfig = override(load_robot_config(robot_path), o.robot, RobotConfig, f"{spec.name}: robot")
        scene = override(load_scene_config(scene_path), o.scene, SceneConfig, f"{spec.name}: scene")
        scene = machine_scene(scene, machine)  # an excavator's pit starts full to the ground
        self.scene: SceneConfig = scene.model_copy(update={"soil": spec.soil}) if spec.soil else scene
        named = f" {shorten(o.goal, 200)}" if isinstance(o.goal, str) else ""
        check_goal(self.goal, self.scene, source=f"{spec.name}: goal{named}",
                   box=None if machine == T3 else machine_box(machine))
        # the machine's own numbers (configs/machines/<machine>.yaml; the T3 has none), then the spec's
        own = load_machine_config(machine)
        self.planner: PlannerConfig = override(
            override(load_planner_config(), own.planner, PlannerConfig, f"machine {machine}: planner"),
            o.planner, PlannerConfig, f"{spec.name}: planner")
        self.executor: ExecutorConfig = override(
            override(load_executor_config(), own.executor, ExecutorConfig, f"machine {machine}: executor"),
            o.executor, ExecutorConfig, f"{spec.name}: executor")
        self.sensing: SensingConfig = override(
            override(load_sensing_config(), own.sensing, SensingConfig, f"machine {machine}: sensing"),
            o.sensing, SensingConfig, f"{spec.name}: sensing")
