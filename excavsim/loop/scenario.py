"""Episode specifications: one episode of any task as data, shared by ``run``, ``trench``, ``campaign`` and ``regress``.

An :class:`EpisodeSpec` names the task and the machine (``task: trench | load | truck``, the tasks
of :mod:`~excavsim.loop.catalog`), the soil, the seed, the stopping rules and overrides of any
configuration file (for trenching the robot, scene, planner, executor and sensing; ``loading:`` and
``truck:`` for the other tasks), written as nested mappings merged over the defaults in
``configs/``. For example, a trench with a weaker wrist and a coarser planner grid::

    name: weak-wrist
    soil: lean_clay
    seed: 3
    robot: {joints: {wrist_pitch: {torque_limit_nm: 500}}}
    planner: {grid: {k_step_m: 0.2}}

:func:`spec_episode` makes its :class:`~excavsim.loop.episode.Episode` (the task's module makes it
through the catalog), :func:`run_spec` builds the world and runs it; :func:`episode_summary` flattens
the result into a JSON-ready dict of numbers (the row a campaign writes and ``regress`` compares),
:func:`dig_rows` gives one row per dig: each the task's own.
"""

from __future__ import annotations

import copy
import pathlib
import re
from collections.abc import Callable
from typing import Any

from pydantic import Field, model_validator

from excavsim import constants
from excavsim.config import (ConfigError, ExecutorConfig, PlannerConfig, RobotConfig, SceneConfig, SensingConfig,
                             StrictModel, TrenchGoal, get_soil, load_config, load_executor_config, load_planner_config,
                             load_robot_config, load_scene_config, load_sensing_config, load_trench_goal,
                             parse_config)
from excavsim.config.machines import load_machine_config, machine_box, machine_scene, machine_trenches_dir
from excavsim.config.semantic import check_goal
from excavsim.errors import UsageError, shorten
from excavsim.robot.machine import MACHINES as TRENCH_MACHINES

TASK_MACHINES = {"trench": tuple(TRENCH_MACHINES), "load": ("loader", "shovel"), "truck": ("t3",),
                 "truck_loading": ("excavator_25t",)}
"""The tasks an episode specification can name, each with the machines that do it (the first is the default).
Trenching's are the machines of :mod:`excavsim.robot.machine`: the T3 and the hydraulic excavators."""
TRENCH_ONLY = ("goal", "done_fraction", "tolerance_m", "robot", "scene", "planner", "executor", "sensing", "memory",
               "predictor")
"""Fields of :class:`EpisodeSpec` that configure the trenching task only."""
FIELD_TASKS: dict[str, tuple[str, ...]] = {**{f: ("trench",) for f in TRENCH_ONLY}, "dig_budget": ("trench", "load", "truck_loading"),
                                           "loading": ("load",), "truck": ("truck",),
                                           "truck_loading": ("truck_loading",)}
"""The fields of :class:`EpisodeSpec` that only some tasks use, each with those tasks (a truck trial is one
dig-swing-dump cycle: it has no dig budget). The other fields (name, task, machine, soil, seed) every task uses."""
TASK_OVERRIDES = {"load": ("loading", "configs/loading_mujoco.yaml"), "truck": ("truck", "configs/truck.yaml"),
                  "truck_loading": ("truck_loading", "configs/truck_loading.yaml")}
"""The field holding each application task's configuration overrides, and the file they apply to."""


class EpisodeSpec(StrictModel):
    """One episode: its task and machine, soil, seed, stopping rules and configuration overrides."""

    name: str = Field(default="episode", description="label for logs and result files")
    task: str = Field(default="trench", description="the task: trench (dig a trench goal with the T3 or a "
                                                    "hydraulic excavator), load "
                                                    "(load from a pile in MuJoCo: excavsim.tasks.load.task) or "
                                                    "truck (one truck-loading trial of the mass-excavation script "
                                                    "on the T3, Rowe 1997 §6.2: excavsim.tasks.truck) or "
                                                    "truck_loading (a truck loaded to full, pass after pass, by the "
                                                    "25 t excavator, Rowe 1997 §4, §6: excavsim.tasks.truck_loading)")
    machine: str | None = Field(default=None, description="the machine: t3 (tasks trench and truck), tb035 or "
                                                          "excavator_25t (task trench: a hydraulic excavator in its "
                                                          "pit, its goals in configs/trenches/<machine>/); loader or "
                                                          "shovel (task load); excavator_25t (task truck_loading); "
                                                          "default the task's first")
    loading: dict[str, Any] = Field(default_factory=dict,
                                    description="overrides of configs/loading_mujoco.yaml (task load)")
    truck: dict[str, Any] = Field(default_factory=dict, description="overrides of configs/truck.yaml (task truck)")
    truck_loading: dict[str, Any] = Field(default_factory=dict, description="overrides of configs/truck_loading.yaml "
                                                                            "(task truck_loading)")
    goal: str | TrenchGoal = Field(
        default="sand", description="a trench of configs/trenches (by name), a YAML path, or the goal inline")
    soil: str | None = Field(default=None, description="soil preset of configs/soils.yaml (default: the scene's)")
    seed: int = Field(default=0, ge=0, le=2**32 - 1, description="episode seed (soil, sensor noise, scanner drift)")
    dig_budget: int = Field(default=20, ge=1, le=1000,
                            description="most digs to try (tasks trench and load; the most passes of task "
                                        "truck_loading; a truck trial is one cycle)")
    done_fraction: float = Field(default=0.95, gt=0, le=1, description="goal volume fraction that counts as done")
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

    @property
    def machine_name(self) -> str:
        """The machine: ``machine``, or the task's default (the first of :data:`TASK_MACHINES`)."""
        return self.machine or TASK_MACHINES[self.task][0]

    @model_validator(mode="after")
    def _check(self) -> EpisodeSpec:
        if self.task not in TASK_MACHINES:
            raise ConfigError(f"unknown task {shorten(repr(self.task))}; allowed: {', '.join(TASK_MACHINES)}")
        machines = TASK_MACHINES[self.task]
        if self.machine is not None and self.machine not in machines:
            raise ConfigError(f"machine {shorten(repr(self.machine))} does not do task {self.task}; allowed: "
                              f"{', '.join(machines)}")
        fields = type(self).model_fields
        given = [f for f, tasks in FIELD_TASKS.items() if self.task not in tasks
                 and getattr(self, f) != fields[f].get_default(call_default_factory=True)]
        sections = {section: (task, path) for task, (section, path) in TASK_OVERRIDES.items()}
        if other := [f for f in given if f not in sections]:
            owners = sorted({t for f in other for t in FIELD_TASKS[f]})
            own = TASK_OVERRIDES.get(self.task)
            raise ConfigError(f"task {self.task} does not use {', '.join(other)} (fields of task "
                              f"{', '.join(owners)})" + (f"; its configuration overrides go in {own[0]}:" if own else ""))
        if given:
            task, path = sections[given[0]]
            raise ConfigError(f"{given[0]}: overrides {path} for task {task}; this spec's task is {self.task}")
        if self.soil is not None:
            get_soil(self.soil)  # raises with the allowed names
        if self.predictor != "wedge":
            from excavsim.learning.predictors import METHODS

            if self.predictor not in METHODS:
                raise ConfigError(f"unknown predictor {self.predictor!r}; allowed: wedge, {', '.join(METHODS)}")
        return self


def merge(base: dict, overrides: dict, *, where: str = "") -> dict:
    """``base`` with ``overrides`` merged in, recursively for nested mappings (a new dict).

    Raises:
        ConfigError: an override names a mapping field with a non-mapping value.
    """
    out = copy.deepcopy(base)
    for key, value in overrides.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = merge(out[key], value, where=f"{where}{key}.")
        else:
            if isinstance(out.get(key), dict):
                raise ConfigError(f"override {where}{key}: expected a mapping of fields, got {value!r}")
            out[key] = value
    return out


def _override(base, overrides: dict, model, label: str):
    if not overrides:
        return base
    return parse_config(merge(base.model_dump(), overrides), model, source=f"{label} overrides")


def load_spec(path: str | pathlib.Path) -> EpisodeSpec:
    """Read and validate an episode specification YAML file."""
    return load_config(path, EpisodeSpec)


def resolve_goal(goal: str | TrenchGoal, machine: str = "t3") -> TrenchGoal:
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
            of = "" if machine == "t3" else f" of machine {machine}"
            raise ConfigError(f"unknown trench goal{of} {shorten(repr(goal))}; give a YAML path or one of: "
                              f"{', '.join(names)}")
    return load_trench_goal(path)


class ResolvedSpec:
    """The configurations an :class:`EpisodeSpec` stands for, with every override applied: for task
    trench the machine, the goal (in the machine's pit) and the robot, scene, planner, executor and sensing
    configurations (the machine's own overrides first, ``configs/machines/<machine>.yaml``); for task load
    ``loading`` (configs/loading_mujoco.yaml with the spec's soil and overrides; its ``max_digs`` is
    the CLI's, an episode of a spec digs at most the spec's ``dig_budget``); for task truck ``truck``
    (configs/truck.yaml with the spec's overrides, a :class:`~excavsim.config.truck.TruckFile`)."""

    def __init__(self, spec: EpisodeSpec, *, robot_path: str | pathlib.Path | None = None,
                 scene_path: str | pathlib.Path | None = None):
        self.spec = spec
        if spec.task == "load":
            from excavsim.config.loading_mujoco import LoadingMujocoConfig, load_loading_mujoco_config

            cfg = _override(load_loading_mujoco_config(), spec.loading, LoadingMujocoConfig, f"{spec.name}: loading")
            self.loading = cfg.model_copy(update={"soil": spec.soil}) if spec.soil else cfg
            return
        if spec.task == "truck":
            from excavsim.config.truck import TruckFile, load_truck_file

            self.truck: TruckFile = _override(load_truck_file(), spec.truck, TruckFile, f"{spec.name}: truck")
            return
        if spec.task == "truck_loading":
            from excavsim.config.truck_loading import TruckLoadingFile, load_truck_loading_file

            self.truck_loading: TruckLoadingFile = _override(load_truck_loading_file(), spec.truck_loading,
                                                             TruckLoadingFile, f"{spec.name}: truck_loading")
            return
        machine = self.machine = spec.machine_name
        if machine != "t3" and spec.robot:
            raise ConfigError(f"{spec.name}: robot: overrides configs/robot.yaml, the T3's servos; machine {machine} "
                              f"drives its joints through its cylinders (models/{machine})")
        self.goal: TrenchGoal = resolve_goal(spec.goal, machine)
        self.robot: RobotConfig = _override(load_robot_config(robot_path), spec.robot, RobotConfig,
                                            f"{spec.name}: robot")
        scene = _override(load_scene_config(scene_path), spec.scene, SceneConfig, f"{spec.name}: scene")
        scene = machine_scene(scene, machine)  # an excavator's pit starts full to the ground
        self.scene: SceneConfig = scene.model_copy(update={"soil": spec.soil}) if spec.soil else scene
        named = f" {shorten(spec.goal, 200)}" if isinstance(spec.goal, str) else ""
        check_goal(self.goal, self.scene, source=f"{spec.name}: goal{named}",
                   box=None if machine == "t3" else machine_box(machine))
        # the machine's own numbers (configs/machines/<machine>.yaml; the T3 has none), then the spec's
        own = load_machine_config(machine)
        self.planner: PlannerConfig = _override(
            _override(load_planner_config(), own.planner, PlannerConfig, f"machine {machine}: planner"),
            spec.planner, PlannerConfig, f"{spec.name}: planner")
        self.executor: ExecutorConfig = _override(
            _override(load_executor_config(), own.executor, ExecutorConfig, f"machine {machine}: executor"),
            spec.executor, ExecutorConfig, f"{spec.name}: executor")
        self.sensing: SensingConfig = _override(
            _override(load_sensing_config(), own.sensing, SensingConfig, f"machine {machine}: sensing"),
            spec.sensing, SensingConfig, f"{spec.name}: sensing")


def spec_episode(spec: EpisodeSpec, resolved: ResolvedSpec | None = None, *,
                 progress: Callable[[str], None] | None = None, observer=None):
    """The :class:`~excavsim.loop.episode.Episode` of ``spec`` (not yet reset): its goal, stopping
    rules and configurations, and its observers (with the online learner of ``spec.predictor``).

    Args:
        resolved: ``spec``'s configurations (default: resolved here from ``configs/``).
    """
    from excavsim.loop.episode import Episode

    r = resolved or ResolvedSpec(spec)
    if spec.task == "load":
        from excavsim.loop.catalog import task_class

        return Episode(task_class("load")(spec.machine_name, cfg=r.loading), dig_budget=spec.dig_budget, progress=progress,
                       observer=observer)
    if spec.task == "truck":  # one trial (one cycle), or a tuning run of its trials
        from excavsim.loop.catalog import task_module

        return task_module("truck").spec_episode(spec, r, progress=progress, observer=observer)
    if spec.task == "truck_loading":  # passes until the truck is full, at most dig_budget
        from excavsim.loop.catalog import task_class

        return Episode(task_class("truck_loading")(spec.machine_name, cfg=r.truck_loading, soil=spec.soil),
                       dig_budget=spec.dig_budget, progress=progress, observer=observer)
    from excavsim.loop.catalog import task_module

    return task_module("trench").spec_episode(spec, r, progress=progress, observer=observer)


def spec_digs(spec: EpisodeSpec):
    """The dig source of ``spec``: for task trench the planner, with the memory of failed digs when
    ``spec.memory``; None (the task's own) otherwise."""
    if spec.task != "trench":
        return None
    from excavsim.loop.catalog import task_module

    return task_module("trench").spec_digs(spec)


def run_spec(spec: EpisodeSpec, *, progress: Callable[[str], None] | None = None, observer=None,
             robot_path: str | pathlib.Path | None = None, scene_path: str | pathlib.Path | None = None):
    """Build the world of ``spec`` and run its episode; returns the task's result (for trench an
    :class:`~excavsim.handoff.episode.EpisodeResult`, for load a
    :class:`~excavsim.tasks.load.task.MujocoRun`, for truck a :class:`~excavsim.tasks.truck.trial.Trial`).

    Args:
        robot_path, scene_path: base configuration files the spec's overrides apply to (default
            configs/robot.yaml and configs/scene.yaml).
    """
    r = ResolvedSpec(spec, robot_path=robot_path, scene_path=scene_path)
    episode = spec_episode(spec, r, progress=progress, observer=observer)
    episode.reset(spec.seed, digs=spec_digs(spec))
    return episode.run()


def _is_loading(res) -> bool:
    """Whether ``res`` is a loading episode's result (a MujocoRun) rather than a trench's."""
    return hasattr(res, "delivered_m3")


def _task_of(res) -> str | None:
    """The registered task whose result ``res`` is, when the result names it (``task``), else None."""
    task = getattr(res, "task", None)
    return task if isinstance(task, str) else None


def _is_truck(res) -> bool:
    """Whether ``res`` is a truck-loading result (a Trial, or a tuning run's) rather than a trench's."""
    return (hasattr(res, "pile") and hasattr(res, "dumped_m3")) or hasattr(res, "tuning_trials")


def run_with_outputs(spec: EpisodeSpec, *, robot_path: str | None = None, scene_path: str | None = None,
                     record: str | None = None, live: str | None = None, save_maps: str | None = None,
                     timing: bool = False, say: Callable[[str], None] = print, command: str = "trench"):
    """``excavsim trench`` and ``excavsim run``: check every file of ``spec``, then run it with its
    outputs, saying the episode, its summary and where the outputs went.

    Args:
        spec: the episode.
        robot_path, scene_path: configuration files the spec's overrides apply to (default ``configs/``).
        record: a Rerun file to record the episode to.
        live: stream the episode to a Rerun viewer: "" spawns one, else its address (checked before
            the episode starts).
        save_maps: a directory for every scanned elevation map (``map_NN.npz``).
        timing: also say Table 7 (Singh 1995 §7.3): the mean per-cycle perception, feasible-set,
            selection, set-up and execution times beside the thesis' Sparc 10 numbers.
        say: where the lines go.
        command: the command that runs it (``trench`` or ``run``), for the first line.

    Returns:
        The episode's result.
    """
    from excavsim.handoff.episode import ObserverGroup, format_episode

    resolved = ResolvedSpec(spec, robot_path=robot_path, scene_path=scene_path)  # every file checked first
    if spec.task != "trench":  # another task of the one episode: run it, say its table, record it if it can
        from excavsim.loop.catalog import task_module

        module = task_module(spec.task)
        recorder = getattr(module, "episode_recorder", None)  # a task's Rerun recorder of its episode, if any
        if live is not None or save_maps or timing or (record and recorder is None):
            can = "only --record" if recorder is not None else "none of them"
            raise UsageError(f"--record, --live, --save-maps and --timing follow trenching episodes; task "
                             f"{spec.task} takes {can}")
        cycles = f"{spec.dig_budget} digs at most"
        if spec.task == "truck":
            tuning = resolved.truck.tuning
            cycles = "one trial" if tuning is None else (f"a {'tuned' if tuning.learn else 'untuned'} run of "
                                                         f"{tuning.trials} trials")
        if spec.task == "truck_loading":
            cycles = f"{spec.dig_budget} passes at most"
        label = "excavsim trench --spec" if command == "trench" else f"excavsim {command}"
        say(f"{label}: task {spec.task}, machine {spec.machine_name}, {cycles}, seed {spec.seed}")
        result = run_spec(spec, progress=say, observer=recorder(record) if record else None)
        say(module.format_run(result))
        if record:
            say(f"recorded to {record}; replay it with: excavsim replay {record}")
        return result
    observer = None
    if record or live is not None:
        from excavsim.record import RerunRecorder
        from excavsim.record.live import viewer_url

        url = viewer_url(live or None) if live is not None else None
        if url:
            say(f"streaming the episode live to {url}")
        observer = RerunRecorder(record, live=url)
    if save_maps:
        from excavsim.loop.episode import MapWriter

        observer = ObserverGroup(observer, MapWriter(save_maps))
    timer = None
    if timing:
        from excavsim.loop.catalog import task_module

        timer = task_module("trench").episode_timer()
        observer = ObserverGroup(observer, timer)
    goal = spec.goal if isinstance(spec.goal, str) else (spec.goal.name or "inline goal")
    by = "" if spec.machine_name == "t3" else f" with the {spec.machine_name}"
    say(f"excavsim {command}: {goal} trench{by}, {spec.dig_budget} digs at most, soil {spec.soil or 'of the scene'}, "
        f"seed {spec.seed}")
    result = run_spec(spec, progress=say, observer=observer, robot_path=robot_path, scene_path=scene_path)
    say(format_episode(result))
    if timer is not None:
        say(timer.table())
    if record:
        say(f"recorded to {record}; replay it with: excavsim replay {record}")
    if save_maps:
        say(f"scanned maps saved in {save_maps} (map_NN.npz); plan on one with: "
            f"excavsim plan --map {save_maps}/map_02.npz")
    return result


def task_of(res) -> str:
    """The task whose result ``res`` is: the task a result names (``task``, e.g. ``truck_loading``), else
    ``truck`` (a trial or a tuning run), ``load`` (a loading episode's run) or ``trench`` (an
    :class:`~excavsim.handoff.episode.EpisodeResult`)."""
    named = _task_of(res)
    if named is not None:
        return named
    if _is_truck(res):
        return "truck"
    return "load" if _is_loading(res) else "trench"


def dig_rows(res) -> list[dict[str, Any]]:
    """One JSON-ready row per dig of an episode, its task's (the ``dig_rows`` of the task's module in
    :mod:`~excavsim.loop.catalog`): for a trench its action (NaN for a fallback dig), volumes [l],
    outcome and failure, and the predicted and measured peak wrist-pitch torques [N m]; for loading
    its action, section and volumes [l] and its peak soil force [kN]; for a truck trial its one cycle."""
    from excavsim.loop.catalog import task_module

    return task_module(task_of(res)).dig_rows(res)


def episode_summary(res) -> dict[str, Any]:
    """The episode's metrics as a flat dict of JSON numbers and strings (one campaign row), its task's
    (the ``summary`` of the task's module in :mod:`~excavsim.loop.catalog`).

    Per-dig lists are reduced to totals, means and peaks; ``end`` is the stopping rule that fired
    (``done``, ``no_dig``, ``budget``, ``diverged`` or ``timeout``), ``reason`` its full text;
    ``diverged_digs`` counts the digs in which the simulation diverged (at most one: the episode ends there).
    A loading episode's and a truck trial's keep the same keys where they mean the same
    (:func:`excavsim.tasks.load.task.summary`, :func:`excavsim.tasks.truck.episode.summary`); a truck
    loaded by the excavator, :func:`excavsim.tasks.truck_loading.task.summary`.
    """
    from excavsim.loop.catalog import task_module

    return task_module(task_of(res)).summary(res)
