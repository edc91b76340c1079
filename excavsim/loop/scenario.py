"""Episode specifications: one episode of any task as data, shared by ``run``, ``campaign`` and ``regress``.

An :class:`EpisodeSpec` has the fields every task has (its name, the task, the machine, the soil, the
seed and the budget of digs) and the task's own, written beside them in the same mapping and
validated by the task's plug-in (:attr:`~excavsim.loop.plugin.TaskPlugin.options`). For example, a
trench with a weaker wrist and a coarser planner grid::

    name: weak-wrist
    task: trench
    soil: lean_clay
    seed: 3
    robot: {joints: {wrist_pitch: {torque_limit_nm: 500}}}
    planner: {grid: {k_step_m: 0.2}}

The platform knows no task's fields: :func:`resolve` asks the task's plug-in for the configurations a
spec stands for, :func:`spec_episode` for its :class:`~excavsim.loop.episode.Episode`, :func:`run_spec`
builds the world and runs it; :func:`episode_summary` flattens the result into a JSON-ready dict of
numbers (the row a campaign writes and ``regress`` compares) and :func:`dig_rows` gives one row per
dig: each the task's own (:mod:`~excavsim.loop.catalog`).
"""

from __future__ import annotations

import copy
import pathlib
from collections.abc import Callable
from typing import Any

from pydantic import Field, model_serializer, model_validator

from excavsim.config import ConfigError, StrictModel, get_soil, load_config, parse_config
from excavsim.errors import UsageError, shorten
from excavsim.loop import catalog
from excavsim.loop.plugin import TaskPlugin

COMMON_FIELDS = ("name", "task", "machine", "soil", "seed", "dig_budget")
"""The fields every task's specification has; the others are the task's own (its plug-in's ``options``)."""
DEFAULT_BUDGET = 20


class EpisodeSpec(StrictModel):
    """One episode: its task and machine, soil, seed and budget, and the task's own fields (:attr:`options`).

    Written as one flat mapping: the task's fields stand beside the common ones (``goal: small`` for a
    trench), and a dump (``model_dump``) gives the same flat mapping back.
    """

    name: str = Field(default="episode", description="label for logs and result files")
    task: str = Field(default=catalog.DEFAULT_TASK,
                      description="the task: a name of the catalog (excavsim.loop.catalog; `excavsim validate "
                                  "--kind spec` lists them), default the catalog's first")
    machine: str | None = Field(default=None, description="the machine that does the task (one of the task's "
                                                          "machines; default the task's first)")
    soil: str | None = Field(default=None, description="soil preset of configs/soils.yaml (default: the task's)")
    seed: int = Field(default=0, ge=0, le=2**32 - 1, description="episode seed (soil, sensor noise, scanner drift)")
    dig_budget: int = Field(default=DEFAULT_BUDGET, ge=1, le=1000,
                            description="most digs (or passes, or trials: the task's budget) to try")
    options: Any = Field(default=None, description="the task's own fields (its plug-in's options model), "
                                                   "written beside the common ones")

    @property
    def plugin(self) -> TaskPlugin:
        """The plug-in of the spec's task."""
        return catalog.plugin(self.task)

    @property
    def machine_name(self) -> str:
        """The machine: ``machine``, or the task's default (its plug-in's first)."""
        return self.machine or self.plugin.machines[0]

    @model_validator(mode="before")
    @classmethod
    def _task_fields(cls, data: Any) -> Any:
        """Hand the fields that are not the platform's to the task's plug-in (its options model)."""
        if not isinstance(data, dict):
            return data
        data = dict(data)
        own = [f for f in cls.model_fields if f != "options"]
        task = data.get("task", catalog.DEFAULT_TASK)
        if not isinstance(task, str):
            raise ConfigError(f"task: {shorten(repr(task))} is not a task name; allowed: {', '.join(catalog.names())}")
        plugin = catalog.plugin(task)
        given = data.pop("options", None)
        rest = {k: data.pop(k) for k in list(data) if k not in own}
        if given is not None:
            if rest:
                raise ConfigError(f"give task {task}'s fields either as options or beside the common fields, not both "
                                  f"({', '.join(map(str, rest))})")
            if isinstance(given, plugin.options):
                data["options"] = given
                return data
            rest = given if isinstance(given, dict) else given.model_dump()
        _check_task_fields(plugin, rest, own)
        data["options"] = parse_config(rest, plugin.options, source=f"task {task}")
        return data

    @model_validator(mode="after")
    def _check(self) -> EpisodeSpec:
        plugin = self.plugin
        if self.machine is not None and self.machine not in plugin.machines:
            raise ConfigError(f"machine {shorten(repr(self.machine))} does not do task {self.task}; allowed: "
                              f"{', '.join(plugin.machines)}")
        if plugin.budget is None and self.dig_budget != DEFAULT_BUDGET:
            raise ConfigError(f"dig_budget: task {self.task} has no budget of digs; leave dig_budget out")
        if self.soil is not None:
            get_soil(self.soil)  # raises with the allowed names
        return self

    @model_serializer(mode="wrap")
    def _flat(self, handler) -> dict[str, Any]:
        data = handler(self)
        options = data.pop("options", None) or {}
        return {**data, **options}


def _check_task_fields(plugin: TaskPlugin, fields: dict[str, Any], common: list[str]) -> None:
    """Refuse a field the task does not have, naming the task it belongs to, or its new name."""
    allowed = plugin.options.model_fields
    for key in fields:
        if key in allowed:
            continue
        if key in plugin.renamed_fields:
            raise ConfigError(f"{key}: task {plugin.name} calls it {plugin.renamed_fields[key]} now; write "
                              f"{plugin.renamed_fields[key]}:")
        owners = [p.name for p in catalog.plugins().values() if key in p.options.model_fields]
        if owners:
            raise ConfigError(f"task {plugin.name} does not use {key} (a field of task {', '.join(owners)})")
        raise ConfigError(f"{shorten(key)}: unknown field; allowed: {', '.join(common)} and task "
                          f"{plugin.name}'s own: {', '.join(allowed) or 'none'}")


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


def override(base, overrides: dict, model, label: str):
    """The configuration ``base`` (a model) with ``overrides`` (a mapping) merged in and validated as
    ``model``; ``base`` itself when there are none. ``label`` says whose overrides they are, for messages."""
    if not overrides:
        return base
    return parse_config(merge(base.model_dump(), overrides), model, source=f"{label} overrides")


def load_spec(path: str | pathlib.Path) -> EpisodeSpec:
    """Read and validate an episode specification YAML file."""
    return load_config(path, EpisodeSpec)


def resolve(spec: EpisodeSpec, *, robot_path: str | pathlib.Path | None = None,
            scene_path: str | pathlib.Path | None = None) -> Any:
    """The configurations ``spec`` stands for, every file read and checked: its task's object
    (:meth:`~excavsim.loop.plugin.TaskPlugin.resolve`).

    Args:
        robot_path, scene_path: base configuration files the spec's overrides apply to (tasks that
            have no such files refuse them).

    Raises:
        ConfigError: naming the file or field and what is allowed.
    """
    return spec.plugin.resolve(spec, robot_path=robot_path, scene_path=scene_path)


ResolvedSpec = resolve  # the older name; the resolved object is the task's own


def spec_episode(spec: EpisodeSpec, resolved: Any = None, *, progress: Callable[[str], None] | None = None,
                 observer=None):
    """The :class:`~excavsim.loop.episode.Episode` of ``spec`` (not yet reset), made by its task's plug-in.

    Args:
        resolved: ``spec``'s configurations (default: :func:`resolve` d here from ``configs/``).
    """
    return spec.plugin.episode(spec, resolved if resolved is not None else resolve(spec), progress=progress,
                               observer=observer)


def spec_digs(spec: EpisodeSpec):
    """The dig source of ``spec``'s episode (its task's; None: the task's own default)."""
    return spec.plugin.digs(spec)


def run_spec(spec: EpisodeSpec, *, progress: Callable[[str], None] | None = None, observer=None,
             robot_path: str | pathlib.Path | None = None, scene_path: str | pathlib.Path | None = None):
    """Build the world of ``spec`` and run its episode; returns the task's result.

    Args:
        robot_path, scene_path: base configuration files the spec's overrides apply to (see :func:`resolve`).
    """
    r = resolve(spec, robot_path=robot_path, scene_path=scene_path)
    episode = spec_episode(spec, r, progress=progress, observer=observer)
    episode.reset(spec.seed, digs=spec_digs(spec))
    return episode.run()


def run_with_outputs(spec: EpisodeSpec, *, robot_path: str | None = None, scene_path: str | None = None,
                     record: str | None = None, live: str | None = None, save_maps: str | None = None,
                     timing: bool = False, say: Callable[[str], None] = print, command: str = "run"):
    """``excavsim run``: check every file of ``spec``, then run it with its outputs, saying the episode,
    its result and where the outputs went.

    Args:
        spec: the episode.
        robot_path, scene_path: configuration files the spec's overrides apply to (default ``configs/``).
        record: a Rerun file to record the episode to (the task's recorder).
        live: stream the episode to the Rerun viewer at this gRPC URL (the caller started or found it:
            :mod:`excavsim.record.live`); for tasks whose recorder streams.
        save_maps, timing: the task's optional outputs (:attr:`~excavsim.loop.plugin.TaskPlugin.outputs`).
        say: where the lines go.
        command: the command that runs it, for the first line.

    Returns:
        The episode's result.

    Raises:
        UsageError: an output the task does not support (naming those it does).
    """
    from excavsim.handoff.episode import ObserverGroup

    plugin = spec.plugin
    resolved = resolve(spec, robot_path=robot_path, scene_path=scene_path)  # every file checked first
    asked = {"live": bool(live), "save_maps": bool(save_maps), "timing": timing}
    if missing := [k for k, on in asked.items() if on and k not in plugin.outputs]:
        options = ", ".join(f"--{k.replace('_', '-')}" for k in missing)
        can = ", ".join(f"--{k.replace('_', '-')}" for k in ("record", *sorted(plugin.outputs)))
        raise UsageError(f"{options}: task {spec.task} does not take {'it' if len(missing) == 1 else 'them'}; "
                         f"it takes {can}")
    observer = plugin.recorder(record, live=live) if (record or live) else None
    if live:
        say(f"streaming the episode live to {live}")
    extra, after = plugin.run_outputs(spec, resolved, save_maps=save_maps, timing=timing)
    if extra is not None:
        observer = ObserverGroup(observer, extra)
    say(f"excavsim {command}: {plugin.describe(spec, resolved)}")
    result = run_spec(spec, progress=say, observer=observer, robot_path=robot_path, scene_path=scene_path)
    say(plugin.format_run(result))
    after(say)
    if record:
        say(f"recorded to {record}; replay it with: excavsim replay {record}")
    return result


def _task_of(res, task: str | None) -> str:
    """``task``, or the task the result ``res`` names (every task's result does: its ``task``)."""
    task = task if task is not None else getattr(res, "task", None)
    if not isinstance(task, str) or not task:
        raise UsageError(f"a {type(res).__name__} that does not say its task; give task= (one of "
                         f"{', '.join(catalog.names())})")
    return task


def dig_rows(res, task: str | None = None) -> list[dict[str, Any]]:
    """One JSON-ready row per dig of an episode (its task's plug-in's ``dig_rows``; ``task`` default: the
    task the result names)."""
    return catalog.plugin(_task_of(res, task)).dig_rows(res)


def episode_summary(res, task: str | None = None) -> dict[str, Any]:
    """The metrics of an episode as a flat dict of JSON numbers and strings (one campaign row), its task's
    plug-in's ``summary`` (``task`` default: the task the result names): ``end`` is the stopping rule that
    fired (``done``, ``no_dig``, ``budget``, ``diverged`` or ``timeout``), ``reason`` its full text; the rest
    is the task's."""
    return catalog.plugin(_task_of(res, task)).summary(res)
