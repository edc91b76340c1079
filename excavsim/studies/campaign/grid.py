"""Campaign specifications and their grids: which episodes a campaign runs, each with a stable id.

A campaign YAML (:class:`CampaignSpec`) names a base :class:`~excavsim.loop.scenario.EpisodeSpec`
and a grid of dotted keys, each with a list of values; :func:`expand_grid` turns it into the
cartesian product of :class:`CampaignEpisode` s, each with an id made of its grid values and a hash of its
specification (so that a resumed or extended campaign recognizes the episodes it has run).
:func:`load_campaign` validates every grid value against the configuration it overrides.

**Campaigns over tasks.** The grid may vary ``task`` (any registered task). A value of ``task`` is a task
name or a mapping of the episode fields that go with that task (its machine, its own fields, its dig
budget), e.g. ``{task: pile_loading, machine: shovel, pile_loading: {n_scans: 2}}``; the mapping must name
``task``. The rule for a task's own fields (its plug-in's ``options``): the **base's** such fields apply
only to the episodes of that task (the base's goal and planner go to the trench episodes; the other tasks'
episodes leave them out), and so does its dig budget for a task that has none, so one base serves every
task; a **grid key** of such a field (e.g. ``planner.grid.k_step_m``) beside a varied task is refused,
since it would run the other tasks' episodes twice: put it in that task's mapping instead. A campaign that
does not vary ``task`` is expanded exactly as before (the same ids).
"""

from __future__ import annotations

import copy
import dataclasses
import hashlib
import itertools
import json
import pathlib
import re
from typing import Annotated, Any

from pydantic import Field

from excavsim.config import StrictModel, load_config, parse_config
from excavsim.errors import ConfigError
from excavsim.loop import catalog
from excavsim.loop.scenario import COMMON_FIELDS, DEFAULT_BUDGET, EpisodeSpec, merge, resolve


def _task_fields() -> dict[str, list[str]]:
    """Every registered task's own fields of a specification -> the tasks that have them."""
    out: dict[str, list[str]] = {}
    for name, plugin in catalog.plugins().items():
        for field in plugin.options.model_fields:
            out.setdefault(field, []).append(name)
    return out


def _short(key: str, value: Any) -> Any:
    """A grid value as it labels an episode: a task's mapping by its task and machine (``load_shovel``)."""
    if key == "task" and isinstance(value, dict):
        return "_".join(str(value[k]) for k in ("task", "machine") if value.get(k))
    return value


def slug(value: Any) -> str:
    """A value as a file-name-safe token (for episode ids and plot names)."""
    text = value if isinstance(value, str) else json.dumps(value, sort_keys=True)
    return re.sub(r"[^A-Za-z0-9_.]+", "_", text).strip("_.")


class CampaignSpec(StrictModel):
    """A campaign: a base episode and a grid of parameters whose cartesian product gives the episodes."""

    name: str = Field(pattern=r"^[A-Za-z0-9][A-Za-z0-9_.-]*$",
                      description="label of the campaign and of its default output directory")
    base: EpisodeSpec = Field(default_factory=EpisodeSpec, description="what every episode shares")
    grid: dict[str, Annotated[list[Any], Field(min_length=1)]] = Field(
        default_factory=dict,
        description="dotted keys of EpisodeSpec (e.g. seed, soil, robot.joints.wrist_pitch.torque_limit_nm, "
                    "goal.depth_m) to the values they take")
    record: bool = Field(default=False, description="write a Rerun recording per episode (recordings/<id>.rrd)")
    report_by: list[Annotated[list[str], Field(min_length=1)]] = Field(
        default_factory=list,
        description="extra summary tables, each grouping the episodes by these grid keys (the others "
                    "pooled), e.g. [[predictor, memory], [soil]]")


@dataclasses.dataclass(frozen=True)
class CampaignEpisode:
    """One point of a campaign's grid: its stable id, readable name, grid values and full specification."""

    id: str
    name: str
    params: dict[str, Any]
    spec: EpisodeSpec


# -- the grid -----------------------------------------------------------------------------------------
def _nested(path: list[str], value: Any) -> dict:
    for part in reversed(path):
        value = {part: value}
    return value


def _apply(data: dict, key: str, value: Any) -> None:
    """Set the dotted ``key`` of episode-spec ``data`` (a model dump) to ``value``, in place."""
    head, *rest = key.split(".")
    if head == "name":
        raise ConfigError("grid key 'name': episode names are made from their grid values; vary another field")
    own = _task_fields()
    if head not in COMMON_FIELDS and head not in own:
        renamed = {old: new for p in catalog.plugins().values() for old, new in p.renamed_fields.items()}
        if head in renamed:
            raise ConfigError(f"grid key {key!r}: {head} is called {renamed[head]} now; write "
                              f"{key.replace(head, renamed[head], 1)!r}")
        raise ConfigError(f"grid key {key!r}: {head!r} is not an episode field; allowed: "
                          f"{', '.join(f for f in COMMON_FIELDS if f != 'name')} and the tasks' own fields "
                          f"({', '.join(own)}; those holding mappings take dotted keys into their fields)")
    if head == "task" and not rest and isinstance(value, dict):  # a task with the fields that go with it
        if not isinstance(value.get("task"), str):
            raise ConfigError(f"grid key 'task': a mapping value must name its task, e.g. {{task: "
                              f"{catalog.DEFAULT_TASK}, machine: ...}}; given {value!r}")
        for key, sub in value.items():
            if isinstance(sub, dict) and isinstance(data.get(key), dict):  # merged over the base's fields
                data[key] = merge(data[key], sub, where=f"{key}.")
            else:
                _apply(data, key, sub)
        return
    if not rest:
        data[head] = value
        return
    current = data.get(head, {})
    if not isinstance(current, dict):  # a field given by name (a trench's goal): the task reads it as a mapping
        task = data.get("task", catalog.DEFAULT_TASK)
        current = catalog.plugin(task).as_mapping(head, current, data) if isinstance(task, str) else None
        if current is None:
            raise ConfigError(f"grid key {key!r}: {head} takes a single value; write {head!r} without a dotted "
                              "suffix")
    data[head] = merge(current, _nested(rest, value), where=f"{head}.")


def _fit_task(data: dict, grid_keys: list[str]) -> None:
    """Leave the fields of other tasks than ``data``'s at their defaults (the base's; see the module
    docstring), in place.

    Raises:
        ConfigError: a grid key (other than ``task``) sets a field of another task while the task varies.
    """
    task = data.get("task", catalog.DEFAULT_TASK)
    if not isinstance(task, str):
        return  # the spec's validation says what is wrong
    plugin = catalog.plugin(task)
    owners = _task_fields()
    budgetless = plugin.budget is None and data.get("dig_budget", DEFAULT_BUDGET) != DEFAULT_BUDGET
    for name in [k for k in data if k not in COMMON_FIELDS and k not in plugin.options.model_fields] + \
            (["dig_budget"] if budgetless else []):
        tasks = owners.get(name, [])
        if keys := [k for k in grid_keys if k.split(".")[0] == name]:
            hint = (f": put it in that task's value, e.g. task: [{{task: {tasks[0]}, {name}: ...}}]"
                    if "task" in grid_keys and tasks else "")
            whose = f"task {', '.join(tasks)} only" if tasks else "the tasks with a budget of digs only"
            raise ConfigError(f"grid key {keys[0]!r} configures {whose}; this episode's task is {task}{hint}")
        if name == "dig_budget":
            data[name] = DEFAULT_BUDGET
        else:
            del data[name]


def episode_id(spec: EpisodeSpec, params: dict[str, Any]) -> str:
    """A stable, file-name-safe id: the grid values (numbers after their key), then a hash of the spec.

    The hash covers the canonical JSON of ``spec`` without its name and without fields left at their
    defaults (so a new EpisodeSpec field does not change the ids of older campaigns).
    """
    canonical = json.dumps(spec.model_dump(mode="json", exclude={"name"}, exclude_defaults=True),
                           sort_keys=True, separators=(",", ":"))
    digest = hashlib.sha256(canonical.encode()).hexdigest()[:10]
    params = {k: _short(k, v) for k, v in params.items()}
    parts = [v if isinstance(v, str) else f"{k.rsplit('.', 1)[-1]}{json.dumps(v)}" for k, v in params.items()]
    label = "-".join(slug(p) for p in parts) if params else slug(spec.name)
    label = label[:60].strip("-_.")
    return f"{label}-{digest}" if label else digest


def expand_grid(spec: CampaignSpec) -> list[CampaignEpisode]:
    """The campaign's episodes: the cartesian product of the grid over the base, in grid order.

    Raises:
        ConfigError: a grid key or value makes an invalid EpisodeSpec, or two points give the same episode.
    """
    keys = list(spec.grid)
    base = spec.base.model_dump()
    episodes: list[CampaignEpisode] = []
    seen: dict[str, str] = {}
    for values in itertools.product(*(spec.grid[k] for k in keys)):
        params = dict(zip(keys, values))
        data = copy.deepcopy(base)
        for key, value in params.items():
            _apply(data, key, value)
        _fit_task(data, keys)
        name = " ".join(f"{k}={slug(_short(k, v))}" for k, v in params.items()) or spec.base.name
        data["name"] = name
        ep = parse_config(data, EpisodeSpec, source=f"campaign {spec.name}: episode {name}")
        eid = episode_id(ep, params)
        if eid in seen:
            raise ConfigError(f"campaign {spec.name}: the grid gives the same episode twice ({seen[eid]!r} and "
                              f"{name!r}); remove the repeated value")
        seen[eid] = name
        episodes.append(CampaignEpisode(eid, name, params, ep))
    return episodes


def check_campaign(spec: CampaignSpec, *, source: str) -> list[CampaignEpisode]:
    """Validate every grid value against the configurations it overrides; returns the episodes.

    Each value is checked alone on the base (so the message names the key and the value); values
    that are only invalid together surface when their episode runs, as an episode error.

    Raises:
        ConfigError: naming ``source``, the grid key, the value and what is wrong.
    """
    try:
        resolve(spec.base)
    except ConfigError as exc:
        raise ConfigError(f"{source}: base: {exc}") from None
    base = spec.base.model_dump()
    for key, values in spec.grid.items():
        for value in values:
            try:
                data = copy.deepcopy(base)
                _apply(data, key, value)
                _fit_task(data, [key])
                resolve(parse_config(data, EpisodeSpec, source=f"grid {key}"))
            except ConfigError as exc:
                raise ConfigError(f"{source}: grid key {key!r}, value {value!r}:\n  {exc}") from None
    for keys in spec.report_by:
        if unknown := [k for k in keys if k not in spec.grid]:
            raise ConfigError(f"{source}: report_by {keys}: {unknown} not among the grid keys "
                              f"{sorted(spec.grid)}")
    try:
        return expand_grid(spec)
    except ConfigError as exc:
        raise ConfigError(f"{source}: {exc}") from None


def parse_campaign(data: Any, *, source: str = "campaign") -> CampaignSpec:
    """Validate an already-parsed campaign mapping, grid included (see :func:`load_campaign`)."""
    spec = parse_config(data, CampaignSpec, source=source)
    check_campaign(spec, source=source)
    return spec


def load_campaign(path: str | pathlib.Path) -> CampaignSpec:
    """Read and validate a campaign YAML file, grid included.

    Raises:
        ConfigError: the file, the field or grid key, the value and what is allowed.
    """
    spec = load_config(path, CampaignSpec)
    check_campaign(spec, source=str(path))
    return spec
