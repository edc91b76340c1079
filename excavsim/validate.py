"""``excavsim validate``: check a configuration file of any kind with every check its use would make.

A file's kind is told from where it lies (a folder of ``configs/`` such as ``campaigns/`` or
``regress/``, or ``configs/<kind>.yaml``, the kind of its stem) or, for a file elsewhere, from its
fields: the kind whose model shares the most top-level fields with it (:func:`infer_kind`). The kinds
(:func:`kinds`) are the platform's (:data:`PLATFORM_KINDS`: the scene, the soils, the sensing,
episode specifications, golden scenarios and the regression baseline, campaigns and experiments) and
each registered task's own (:attr:`excavsim.loop.plugin.TaskPlugin.config_kinds`): ``validate`` names
none of them. ``excavsim validate --help`` lists them all.

Every refusal is a :class:`~excavsim.errors.ConfigError` naming the file, the field and what is
allowed; ``excavsim validate`` prints it and exits with status 2.
"""

from __future__ import annotations

import os
import pathlib
from collections.abc import Callable, Iterable, Iterator

from pydantic import BaseModel

from excavsim import config as c
from excavsim.config.baseline import RegressBaseline, load_baseline_file
from excavsim.config.kinds import ConfigKind, plain_kind
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


def _experiment_spec() -> type[BaseModel]:
    from excavsim.studies.experiment import ExperimentSpec

    return ExperimentSpec


def _count(n: int, noun: str) -> str:
    return f"{n} {noun}{'' if n == 1 else 's'}"


def _resolved(spec, source: str) -> None:
    """Resolve an episode specification as its task does (its overrides merged, its files checked)."""
    from excavsim.loop.scenario import resolve

    try:
        resolve(spec)
    except ConfigError as exc:
        raise ConfigError(f"{source}{exc}") from None


# -- the checks of the platform's kinds: load with every check the file's use makes; say what it holds --------
def _spec(path: pathlib.Path) -> str:
    from excavsim.loop.scenario import load_spec

    _resolved(load_spec(path), f"{_where(path)}: ")
    return "EpisodeSpec (resolved as its task resolves it)"


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
    from excavsim.loop import catalog

    doc = load_baseline_file(path)
    for name, scenario in doc.scenarios.items():
        try:
            allowed = tuple(catalog.plugin(scenario.task).metrics)
        except ConfigError as exc:
            raise ConfigError(f"{_where(path)}: scenarios.{shorten(name)}.task: {exc}") from None
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


PLATFORM_KINDS = (
    plain_kind("scene", c.SceneConfig, "the world (configs/scene.yaml)", stem=True),
    plain_kind("soils", c.SoilsFile, "the soil presets (configs/soils.yaml)", stem=True),
    plain_kind("sensing", c.SensingConfig, "scanner, map, F/T (configs/sensing.yaml)", stem=True),
    ConfigKind("spec", _episode_spec, _spec, "an episode specification of any task (configs/specs/*.yaml)",
               folders=("specs",)),
    ConfigKind("regress", _golden_scenario, _regress, "a golden scenario (configs/regress/*.yaml)",
               folders=("regress",)),
    ConfigKind("baseline", lambda: RegressBaseline, _baseline, "the regression baseline (configs/regress/baseline.json)"),
    ConfigKind("campaign", _campaign_spec, _campaign, "a campaign (configs/campaigns/*.yaml)", folders=("campaigns",)),
    ConfigKind("experiment", _experiment_spec, _experiment, "a thesis experiment (configs/experiments/*.yaml)",
               folders=("experiments",)),
)
"""The platform's kinds of configuration file; the tasks add theirs (:func:`kinds`)."""


def kinds() -> dict[str, ConfigKind]:
    """Every kind of configuration file ``validate`` knows: the platform's, then each registered task's.

    Raises:
        ConfigError: two kinds share a name.
    """
    from excavsim.loop import catalog

    out = {k.name: k for k in PLATFORM_KINDS}
    for plugin in catalog.plugins().values():
        for kind in plugin.config_kinds:
            if kind.name in out:
                raise ConfigError(f"task {plugin.name}: kind of configuration file {kind.name!r} exists already")
            out[kind.name] = kind
    return out


def _folder_kinds(folder: str, parent: str) -> list[str]:
    """The kinds whose files lie in ``configs/<folder>/`` (or in a subfolder of ``configs/<parent>/``)."""
    return [k.name for k in kinds().values() if folder in k.folders or (k.subfolders and parent in k.folders)]


def _stem_kinds() -> list[str]:
    return [k.name for k in kinds().values() if k.stem]


def _fields(kind: str) -> frozenset[str]:
    return frozenset(kinds()[kind].model().model_fields)


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
                          f"{', '.join(kinds())})")
    return tied[0]


def infer_kind(path: str | os.PathLike) -> str:
    """The kind of the configuration file ``path``: from its folder and stem, else from its fields.

    Raises:
        ConfigError: the file cannot be read or its kind cannot be told (the message lists the kinds).
    """
    path = pathlib.Path(path)
    if path.suffix == ".json":
        return "baseline"
    folder = _folder_kinds(path.parent.name, path.parent.parent.name)
    if folder:
        return folder[0] if len(folder) == 1 else _by_fields(path, folder)
    stems = _stem_kinds()
    if path.stem in stems:
        return path.stem
    # a variant named after its kind (sensing_testbed.yaml): the longest kind the stem starts with
    prefixed = [k for k in stems if path.stem.startswith(f"{k}_")]
    if prefixed:
        return max(prefixed, key=len)
    return _by_fields(path, kinds())


def validate_file(path: str | os.PathLike, kind: str | None = None) -> tuple[str, str]:
    """Check the configuration file ``path`` as its use would; returns its kind and what it holds.

    Args:
        path: the file.
        kind: one of :func:`kinds` (default: :func:`infer_kind`).

    Raises:
        ConfigError: naming the file, the field and what is allowed.
    """
    known = kinds()
    if kind is not None and kind not in known:
        raise ConfigError(f"unknown kind of configuration file {shorten(repr(kind))}; allowed: {', '.join(known)}")
    kind = kind or infer_kind(path)
    return kind, known[kind].check(pathlib.Path(path))


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
    if kind is None and len(items) > 1 and items[0] in kinds() and not os.path.exists(items[0]):
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
