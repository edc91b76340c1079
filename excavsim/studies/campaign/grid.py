"""Campaign specifications and their grids: which episodes a campaign runs, each with a stable id.

A campaign YAML (:class:`CampaignSpec`) names a base :class:`~excavsim.loop.scenario.EpisodeSpec`
and a grid of dotted keys, each with a list of values; :func:`expand_grid` turns it into the
cartesian product of :class:`Episode` s, each with an id made of its grid values and a hash of its
specification (so that a resumed or extended campaign recognizes the episodes it has run).
:func:`load_campaign` validates every grid value against the configuration it overrides.

**Campaigns over tasks.** The grid may vary ``task`` (trench, load, truck). A value of ``task`` is a task
name or a mapping of the episode fields that go with that task (its machine, its configuration
overrides, its dig budget), e.g. ``{task: load, machine: shovel, loading: {n_scans: 2}}``; the mapping
must name ``task``. The rule for fields that belong to one task
(:data:`~excavsim.loop.scenario.FIELD_TASKS`): the **base's** such fields apply only to the episodes of
the tasks they belong to (the base's goal and planner go to the trench episodes; a load or truck
episode leaves them at their defaults), so one base serves every task; a **grid key** of such a field
(e.g. ``planner.grid.k_step_m``) beside a varied task is refused, since it would run the other tasks'
episodes twice: put it in that task's mapping instead. A campaign that does not vary ``task`` is
expanded exactly as before (the same ids).
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
from excavsim.loop.scenario import FIELD_TASKS, EpisodeSpec, ResolvedSpec, merge, resolve_goal

OVERRIDE_SECTIONS = ("robot", "scene", "planner", "executor", "sensing", "loading", "truck", "truck_loading")


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
class Episode:
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
    if head not in EpisodeSpec.model_fields:
        raise ConfigError(f"grid key {key!r}: {head!r} is not an episode field; allowed: "
                          f"{', '.join(f for f in EpisodeSpec.model_fields if f != 'name')} "
                          f"(goal and {', '.join(OVERRIDE_SECTIONS)} take dotted keys into their fields)")
    if head == "task" and not rest and isinstance(value, dict):  # a task with the fields that go with it
        if not isinstance(value.get("task"), str):
            raise ConfigError(f"grid key 'task': a mapping value must name its task, e.g. {{task: load, machine: "
                              f"shovel}}; given {value!r}")
        for key, sub in value.items():
            if key in OVERRIDE_SECTIONS and isinstance(sub, dict):  # merged over the base's overrides
                data[key] = merge(data[key], sub, where=f"{key}.")
            else:
                _apply(data, key, sub)
        return
    if not rest:
        data[head] = value
    elif head == "goal":
        goal = data["goal"] if isinstance(data["goal"], dict) else resolve_goal(data["goal"]).model_dump()
        data["goal"] = merge(goal, _nested(rest, value), where="goal.")
    elif head in OVERRIDE_SECTIONS:
        data[head] = merge(data[head], _nested(rest, value), where=f"{head}.")
    else:
        raise ConfigError(f"grid key {key!r}: {head} takes a single value; write {head!r} without a dotted suffix")


def _fit_task(data: dict, grid_keys: list[str]) -> None:
    """Leave the fields of other tasks than ``data``'s at their defaults (the base's; see the module
    docstring), in place.

    Raises:
        ConfigError: a grid key (other than ``task``) sets a field of another task while the task varies.
    """
    task = data.get("task", "trench")
    fields = EpisodeSpec.model_fields
    for name, tasks in FIELD_TASKS.items():
        if task in tasks:
            continue
        default = fields[name].get_default(call_default_factory=True)
        if (keys := [k for k in grid_keys if k.split(".")[0] == name]) and data[name] != default:
            hint = (f": put it in that task's value, e.g. task: [{{task: {tasks[0]}, {name}: ...}}]"
                    if "task" in grid_keys else "")
            raise ConfigError(f"grid key {keys[0]!r} configures task {', '.join(tasks)} only; this episode's task "
                              f"is {task}{hint}")
        data[name] = default


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


def expand_grid(spec: CampaignSpec) -> list[Episode]:
    """The campaign's episodes: the cartesian product of the grid over the base, in grid order.

    Raises:
        ConfigError: a grid key or value makes an invalid EpisodeSpec, or two points give the same episode.
    """
    keys = list(spec.grid)
    base = spec.base.model_dump()
    episodes: list[Episode] = []
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
        episodes.append(Episode(eid, name, params, ep))
    return episodes


def check_campaign(spec: CampaignSpec, *, source: str) -> list[Episode]:
    """Validate every grid value against the configurations it overrides; returns the episodes.

    Each value is checked alone on the base (so the message names the key and the value); values
    that are only invalid together surface when their episode runs, as an episode error.

    Raises:
        ConfigError: naming ``source``, the grid key, the value and what is wrong.
    """
    try:
        ResolvedSpec(spec.base)
    except ConfigError as exc:
        raise ConfigError(f"{source}: base: {exc}") from None
    base = spec.base.model_dump()
    for key, values in spec.grid.items():
        for value in values:
            try:
                data = copy.deepcopy(base)
                _apply(data, key, value)
                _fit_task(data, [key])
                ResolvedSpec(parse_config(data, EpisodeSpec, source=f"grid {key}"))
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
