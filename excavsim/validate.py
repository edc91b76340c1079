"""``excavsim validate``: check a configuration file of any kind with every check its use would make.

A file's kind is told from where it lies (``configs/trenches/`` holds goals, ``configs/campaigns/``
campaigns, ``configs/experiments/`` experiments, ``configs/regress/`` golden scenarios and the
baseline, ``configs/<kind>.yaml`` the kind of its stem) or, for a file elsewhere, from its fields:
the kind whose model shares the most top-level fields with it (:func:`infer_kind`). The kinds
(:data:`KINDS`) are every file ``configs/`` holds:

========================  =====================================================================
kind                      what is checked
========================  =====================================================================
robot, scene, soils,      the file's schema (:mod:`excavsim.config`)
sensing, planner,
executor
goal                      a trench goal, against the soil box and the initial soil of
                          ``configs/scene.yaml`` (:func:`~excavsim.config.semantic.check_goal`);
                          one in ``configs/trenches/<machine>/`` against that machine's pit
spec                      an episode specification, its overrides and goal resolved
regress                   a golden scenario of ``excavsim regress``: its seeds, its specification resolved
baseline                  the regression baseline (JSON): one value per seed, known metrics
campaign                  a trench campaign, every grid value
experiment                a thesis experiment, every run resolved
loading                   the 2-D loading simulation (``excavsim load``)
loading_mujoco            loading from a pile in MuJoCo (``excavsim load --mujoco``)
loading_campaign          a campaign of MuJoCo loading episodes (``excavsim load --campaign``),
                          its ``mujoco_config`` too
truck                     truck loading by the self-tuned mass-excavation script (``excavsim truck``)
machine                   a trenching machine's overrides of the planner, executor and sensing files
                          (``configs/machines/``), each merged and checked
truck_loading             a truck loaded to full by the 25 t excavator (task ``truck_loading``)
========================  =====================================================================

Every refusal is a :class:`~excavsim.errors.ConfigError` naming the file, the field and what is
allowed; ``excavsim validate`` prints it and exits with status 2.
"""

from __future__ import annotations

import dataclasses
import os
import pathlib
from collections.abc import Callable, Iterable, Iterator

from pydantic import BaseModel

from excavsim import config as c
from excavsim.config.baseline import RegressBaseline, load_baseline_file
from excavsim.config.loading import LoadingConfig, load_loading_config
from excavsim.config.loading_mujoco import (LoadingCampaign, LoadingMujocoConfig, load_loading_campaign,
                                           load_loading_mujoco_config)
from excavsim.config.truck import TruckFile, load_truck_file
from excavsim.config.truck_loading import TruckLoadingFile, load_truck_loading_file
from excavsim.errors import ConfigError, ExcavsimError, shorten

SUFFIXES = (".yaml", ".yml", ".json")  # the files a directory given to validate contributes


def _where(path: str | os.PathLike) -> str:
    return c.display_path(path)


# -- the models of the upper layers, imported when first needed ------------------------------------------
def _episode_spec() -> type[BaseModel]:
    from excavsim.loop.scenario import EpisodeSpec

    return EpisodeSpec


def _golden_scenario() -> type[BaseModel]:
    from excavsim.studies.regress.suite import GoldenScenario

    return GoldenScenario


def _campaign_spec() -> type[BaseModel]:
    from excavsim.studies.campaign.runner import CampaignSpec

    return CampaignSpec


def _machine_config() -> type[BaseModel]:
    from excavsim.config.machines import MachineConfig

    return MachineConfig


def _experiment_spec() -> type[BaseModel]:
    from excavsim.studies.experiment import ExperimentSpec

    return ExperimentSpec


def _count(n: int, noun: str) -> str:
    return f"{n} {noun}{'' if n == 1 else 's'}"


def _resolved(spec, source: str) -> None:
    """Resolve an episode specification (its overrides merged, its goal checked against its scene)."""
    from excavsim.loop.scenario import ResolvedSpec

    try:
        ResolvedSpec(spec)
    except ConfigError as exc:
        raise ConfigError(f"{source}{exc}") from None


# -- the checks of each kind: load with every check the file's use makes; say what it holds ----------------
def _plain(model: type[BaseModel]) -> Callable[[pathlib.Path], str]:
    def check(path: pathlib.Path) -> str:
        return c.load_config(path, model).__class__.__name__
    return check


def _goal(path: pathlib.Path) -> str:
    from excavsim.config.machines import machine_box, machine_scene

    # configs/trenches/<machine>/ holds another machine's goals, in its pit's coordinates
    machine = path.parent.name if path.parent.parent.name == "trenches" else "t3"
    c.check_goal(c.load_trench_goal(path), machine_scene(c.load_scene_config(), machine), source=_where(path),
                 box=machine_box(machine) if machine != "t3" else None)
    where = "the soil box" if machine == "t3" else f"the {machine}'s pit"
    return f"TrenchGoal (inside {where}, below the initial soil of configs/scene.yaml)"


def _machine(path: pathlib.Path) -> str:
    from excavsim.config.machines import MachineConfig

    cfg = c.load_config(path, MachineConfig)

    class Merged(c.StrictModel):
        planner: c.PlannerConfig
        executor: c.ExecutorConfig
        sensing: c.SensingConfig

    bases = {"planner": c.load_planner_config, "executor": c.load_executor_config, "sensing": c.load_sensing_config}
    c.parse_config({k: _merged(load().model_dump(), getattr(cfg, k)) for k, load in bases.items()}, Merged,
                   source=_where(path))
    return "MachineConfig (its overrides merged over configs/planner.yaml, executor.yaml and sensing.yaml)"


def _merged(base: dict, over: dict) -> dict:
    out = dict(base)
    for k, v in over.items():
        out[k] = _merged(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


def _spec(path: pathlib.Path) -> str:
    from excavsim.loop.scenario import load_spec

    _resolved(load_spec(path), f"{_where(path)}: ")
    return "EpisodeSpec (overrides and goal resolved)"


def _regress(path: pathlib.Path) -> str:
    from excavsim.studies.regress.suite import GoldenScenario
    from excavsim.loop.scenario import EpisodeSpec

    golden = c.load_config(path, GoldenScenario)
    seeds = list(range(golden.seed, golden.seed + golden.seeds)) if isinstance(golden.seeds, int) else golden.seeds
    if max(seeds) > 2**32 - 1:
        raise ConfigError(f"{_where(path)}: seeds: the seeds run to {max(seeds)}; allowed: seeds up to 2^32 - 1")
    _resolved(EpisodeSpec.model_validate(golden.model_dump(exclude={"seeds"})), f"{_where(path)}: ")
    return f"GoldenScenario ({_count(len(seeds), 'seed')}, specification resolved)"


def _baseline(path: pathlib.Path) -> str:
    from excavsim.studies.regress.suite import TASK_METRICS

    doc = load_baseline_file(path)
    for name, scenario in doc.scenarios.items():
        allowed = TASK_METRICS[scenario.task]
        unknown = sorted(set(scenario.metrics) - set(allowed))
        if unknown:
            raise ConfigError(f"{_where(path)}: scenarios.{shorten(name)}.metrics: unknown {shorten(unknown)}; "
                              f"allowed for task {scenario.task}: {', '.join(allowed)}")
    return f"RegressBaseline (format {doc.format}, {_count(len(doc.scenarios), 'scenario')})"


def _campaign(path: pathlib.Path) -> str:
    from excavsim.studies.campaign.runner import load_campaign

    return f"CampaignSpec ({_count(len(load_campaign(path).grid), 'grid key')}, every value checked)"


def _experiment(path: pathlib.Path) -> str:
    from excavsim.studies.experiment import ExperimentSpec

    exp = c.load_config(path, ExperimentSpec)
    for run in exp.runs:
        _resolved(run, f"{_where(path)}: run {shorten(run.name)}: ")
    return f"ExperimentSpec ({_count(len(exp.runs), 'run')}, each resolved)"


def _loading(path: pathlib.Path) -> str:
    load_loading_config(path)
    return "LoadingConfig"


def _loading_mujoco(path: pathlib.Path) -> str:
    load_loading_mujoco_config(path)
    return "LoadingMujocoConfig"


def _loading_campaign(path: pathlib.Path) -> str:
    spec = load_loading_campaign(path)
    if spec.mujoco_config is not None:  # read as `excavsim load --campaign` reads it: relative to the working directory
        try:
            load_loading_mujoco_config(spec.mujoco_config)
        except ConfigError as exc:
            raise ConfigError(f"{_where(path)}: mujoco_config: {exc}") from None
    return f"LoadingCampaign ({_count(len(spec.machines), 'machine')} x {_count(len(spec.seeds), 'seed')})"


def _truck(path: pathlib.Path) -> str:
    load_truck_file(path)
    return "TruckFile"


def _truck_loading(path: pathlib.Path) -> str:
    load_truck_loading_file(path)
    return "TruckLoadingFile"


@dataclasses.dataclass(frozen=True)
class Kind:
    """A kind of configuration file: its name, its model (whose fields tell a file's kind from its
    contents), the check ``excavsim validate`` makes, and what it is."""

    name: str
    model: Callable[[], type[BaseModel]]
    check: Callable[[pathlib.Path], str]
    what: str


def _const(model: type[BaseModel]) -> Callable[[], type[BaseModel]]:
    return lambda: model


_KIND_LIST = (
    Kind("robot", _const(c.RobotConfig), _plain(c.RobotConfig), "the T3's joints and servos (configs/robot.yaml)"),
    Kind("scene", _const(c.SceneConfig), _plain(c.SceneConfig), "the world (configs/scene.yaml)"),
    Kind("soils", _const(c.SoilsFile), _plain(c.SoilsFile), "the soil presets (configs/soils.yaml)"),
    Kind("sensing", _const(c.SensingConfig), _plain(c.SensingConfig), "scanner, map, F/T (configs/sensing.yaml)"),
    Kind("planner", _const(c.PlannerConfig), _plain(c.PlannerConfig), "the trench planner (configs/planner.yaml)"),
    Kind("executor", _const(c.ExecutorConfig), _plain(c.ExecutorConfig), "the dig script (configs/executor.yaml)"),
    Kind("goal", _const(c.TrenchGoal), _goal, "a trench goal (configs/trenches/*.yaml)"),
    Kind("spec", _episode_spec, _spec, "an episode specification"),
    Kind("regress", _golden_scenario, _regress, "a golden scenario (configs/regress/*.yaml)"),
    Kind("baseline", _const(RegressBaseline), _baseline, "the regression baseline (configs/regress/baseline.json)"),
    Kind("campaign", _campaign_spec, _campaign, "a trench campaign (configs/campaigns/*.yaml)"),
    Kind("experiment", _experiment_spec, _experiment, "a thesis experiment (configs/experiments/*.yaml)"),
    Kind("loading", _const(LoadingConfig), _loading, "the 2-D loading simulation (configs/loading.yaml)"),
    Kind("loading_mujoco", _const(LoadingMujocoConfig), _loading_mujoco,
         "loading from a pile in MuJoCo (configs/loading_mujoco.yaml)"),
    Kind("loading_campaign", _const(LoadingCampaign), _loading_campaign,
         "a campaign of MuJoCo loading episodes (configs/campaigns/loading_mujoco.yaml)"),
    Kind("truck", _const(TruckFile), _truck, "truck loading by the self-tuned script (configs/truck.yaml)"),
    Kind("machine", _machine_config, _machine, "a trenching machine's overrides (configs/machines/*.yaml)"),
    Kind("truck_loading", _const(TruckLoadingFile), _truck_loading,
         "a truck loaded to full by the 25 t excavator (configs/truck_loading.yaml)"),
)
KINDS: dict[str, Kind] = {k.name: k for k in _KIND_LIST}

# Where a file lies tells its kind: a folder of configs/ (several kinds: told apart by the fields), else a stem.
FOLDER_KINDS = {"trenches": ("goal",), "campaigns": ("campaign", "loading_campaign"), "experiments": ("experiment",),
                "regress": ("regress",), "specs": ("spec",), "machines": ("machine",)}
STEM_KINDS = ("robot", "scene", "soils", "sensing", "planner", "executor", "loading", "loading_mujoco", "truck",
              "truck_loading")


def _fields(kind: str) -> frozenset[str]:
    return frozenset(KINDS[kind].model().model_fields)


def _by_fields(path: pathlib.Path, candidates: Iterable[str]) -> str:
    """Among ``candidates``, the kind whose model shares the most top-level fields with the file's; a tie goes
    to the kind whose fields hold no other tied kind's fields (an episode specification before a golden scenario,
    which adds ``seeds``)."""
    candidates = tuple(candidates)
    where = _where(path)
    data = c.parse_yaml(c.read_text_file(path, "configuration", where=where), source=where)
    if not isinstance(data, dict):
        raise ConfigError(f"{where}: the top level must be a mapping of fields, got {type(data).__name__}")
    keys = {k for k in data if isinstance(k, str)}
    score = {k: len(keys & _fields(k)) for k in candidates}
    best = max(score.values())
    tied = [k for k in candidates if score[k] == best]
    tied = [k for k in tied if not any(o != k and _fields(o) < _fields(k) for o in tied)]
    if best == 0 or len(tied) > 1:
        could = ", ".join(tied if best else candidates)
        raise ConfigError(f"{where}: cannot tell what the file configures from its place or its fields (it could be "
                          f"{could}); give its kind: excavsim validate --kind KIND FILE (allowed kinds: "
                          f"{', '.join(KINDS)})")
    return tied[0]


def infer_kind(path: str | os.PathLike) -> str:
    """The kind of the configuration file ``path``: from its folder and stem, else from its fields.

    Raises:
        ConfigError: the file cannot be read or its kind cannot be told (the message lists the kinds).
    """
    path = pathlib.Path(path)
    if path.suffix == ".json":
        return "baseline"
    folder = FOLDER_KINDS.get(path.parent.name)
    if folder is None and path.parent.parent.name == "trenches":  # configs/trenches/<machine>/: its goals
        folder = FOLDER_KINDS["trenches"]
    if folder is not None:
        return folder[0] if len(folder) == 1 else _by_fields(path, folder)
    if path.stem in STEM_KINDS:
        return path.stem
    # a variant named after its kind (sensing_testbed.yaml): the longest kind the stem starts with
    prefixed = [k for k in STEM_KINDS if path.stem.startswith(f"{k}_")]
    if prefixed:
        return max(prefixed, key=len)
    return _by_fields(path, KINDS)


def validate_file(path: str | os.PathLike, kind: str | None = None) -> tuple[str, str]:
    """Check the configuration file ``path`` as its use would; returns its kind and what it holds.

    Args:
        path: the file.
        kind: one of :data:`KINDS` (default: :func:`infer_kind`).

    Raises:
        ConfigError: naming the file, the field and what is allowed.
    """
    if kind is not None and kind not in KINDS:
        raise ConfigError(f"unknown kind of configuration file {shorten(repr(kind))}; allowed: {', '.join(KINDS)}")
    kind = kind or infer_kind(path)
    return kind, KINDS[kind].check(pathlib.Path(path))


def _expand(items: Iterable[str | os.PathLike]) -> Iterator[pathlib.Path]:
    """The files of ``items``: a directory stands for every configuration file under it (sorted)."""
    for item in items:
        p = pathlib.Path(item)
        if p.is_dir():
            found = sorted(f for f in p.rglob("*") if f.is_file() and f.suffix in SUFFIXES)
            if not found:
                raise ConfigError(f"{_where(p)}: no configuration files ({', '.join(SUFFIXES)}) in the directory")
            yield from found
        else:
            yield p


def validate_paths(items: list[str], kind: str | None = None) -> Iterator[str]:
    """``excavsim validate FILE...``: check every file (a directory: every configuration file under it),
    yielding one line per valid file; the refusals come together at the end.

    ``KIND FILE`` (the older form, a kind name first) is read as ``--kind KIND FILE``.

    Raises:
        ConfigError: after the last file, one paragraph per refused file, each naming the file and the field.
    """
    items = list(items)
    if kind is None and len(items) > 1 and items[0] in KINDS and not os.path.exists(items[0]):
        kind, items = items[0], items[1:]
    refusals = []
    for path in _expand(items):
        try:
            found, what = validate_file(path, kind)
        except ExcavsimError as exc:  # every refusal names its file
            text, where = str(exc), _where(path)
            refusals.append(text if where in text.split("\n", 1)[0] else f"{where}: {text}")
            continue
        yield f"{shorten(str(path), 200)}: valid {what}; kind {found}"
    if refusals:
        raise ConfigError("\n".join(refusals))
