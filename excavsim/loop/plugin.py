"""The task plug-in contract: everything the platform, the CLI, ``validate`` and the studies ask of a task.

A task is one folder, ``excavsim/tasks/<name>/`` (or a package of another distribution), whose
``plugin`` module defines one subclass of :class:`TaskPlugin` and is named by one line of the catalog
(:mod:`excavsim.loop.catalog`) or by an entry point of the group ``excavsim.tasks``. Nothing outside
the folder and the catalog says the task's name: the episode specification asks the plug-in for its
fields (:attr:`TaskPlugin.options`), the campaign for its metrics and columns, ``regress`` for its
tolerances, ``validate`` for its configuration kinds, the CLI for its commands, the environments'
registry for its environments. It is the shape of dm_control's suite (a domain is a module found by
attribute) and of Gymnasium's ``register(id, entry_point)``: a researcher who brings a task writes one
folder and one line.

A plug-in module must stay light to import (no MuJoCo, no world, no mind at its top): the CLI reads
every plug-in to build its parser, ``validate`` to know the kinds of file. Its methods import the
task's heavy modules when they are called.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from typing import Any, ClassVar

from excavsim.config.kinds import ConfigKind
from excavsim.config.loader import StrictModel
from excavsim.errors import ConfigError, UsageError

# The hooks' types, by name (imported by no module here: the plug-in module stays light and below them):
# EpisodeSpec (excavsim.loop.scenario), Episode (excavsim.loop.episode), EpisodeObserver
# (excavsim.handoff.episode), argparse._SubParsersAction.
EpisodeSpec = Episode = EpisodeObserver = Any


@dataclasses.dataclass(frozen=True)
class Metric:
    """How ``regress`` judges one metric of a task's summary: ``better`` is "higher" or "lower"; only a
    worsening by more than ``abs_tol`` + ``rel_tol`` x |reference mean| can be a regression."""

    better: str
    abs_tol: float
    rel_tol: float = 0.0

    def __post_init__(self):
        if self.better not in ("higher", "lower"):
            raise ValueError(f"Metric.better must be 'higher' or 'lower', given {self.better!r}")

    def tolerance(self, reference_mean: float) -> float:
        """The practical tolerance against a reference sample of this mean, in the metric's units."""
        return self.abs_tol + self.rel_tol * abs(reference_mean)


@dataclasses.dataclass(frozen=True)
class EnvEntry:
    """An environment a task contributes: registered with Gymnasium as ``id`` (``entry_point`` is
    ``module:Class``; ``kwargs`` its defaults; ``vector_entry_point`` a batched implementation, if any)."""

    id: str
    entry_point: str
    kwargs: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    vector_entry_point: str | None = None


class NoOptions(StrictModel):
    """The fields of a task that adds none to the episode specification."""


class TaskPlugin:
    """A task as the platform knows it. Subclass it in the task's ``plugin`` module and set the class
    attributes; override the hooks the task has (the defaults say what a task without them does).

    Attributes:
        name: the task's name in specifications (``task: NAME``), campaigns and results; lowercase
            words joined by ``_``.
        title: one line saying what the task is, with its source (for ``--help`` and the docs).
        machines: the machines that do it, the default first (names of :mod:`excavsim.robot.registry`).
        options: the task's own fields of an episode specification, with their defaults (a
            :class:`~excavsim.config.loader.StrictModel`); the common ones (name, task, machine, soil,
            seed, dig_budget) belong to the platform.
        renamed_fields: old fields of the task's specification -> the new name (refused, naming it).
        budget: what the specification's ``dig_budget`` counts for this task (``digs``, ``passes``), or
            None when the task has no budget (setting one is then refused).
        metrics: the summary's keys that ``regress`` judges, with their tolerances.
        columns: the summary's keys a campaign's table shows for the task beyond the common ones (digs,
            l/dig, stalls, removed %), each with its column's heading.
        config_kinds: the kinds of configuration file the task adds to ``excavsim validate``.
        environments: the Gymnasium environments the task contributes.
        dig_sources: the task's dig sources by name (``module:callable``), for callers that choose the
            digs of an episode (the calibration's digs, a benchmark's entries).
        outputs: the optional outputs of ``excavsim run`` the task supports besides ``record``
            (``live``, ``save_maps``, ``timing``).
    """

    name: ClassVar[str]
    title: ClassVar[str]
    machines: ClassVar[tuple[str, ...]]
    options: ClassVar[type[StrictModel]] = NoOptions
    renamed_fields: ClassVar[Mapping[str, str]] = {}
    budget: ClassVar[str | None] = "digs"
    metrics: ClassVar[Mapping[str, Metric]] = {}
    columns: ClassVar[tuple[tuple[str, str], ...]] = ()
    config_kinds: ClassVar[tuple[ConfigKind, ...]] = ()
    environments: ClassVar[tuple[EnvEntry, ...]] = ()
    dig_sources: ClassVar[Mapping[str, str]] = {}
    outputs: ClassVar[frozenset[str]] = frozenset()

    # -- the episode -----------------------------------------------------------------------------------
    def resolve(self, spec: EpisodeSpec, *, robot_path=None, scene_path=None) -> Any:
        """The configurations ``spec`` stands for, every file read and checked (the task's own object;
        :func:`~excavsim.loop.scenario.resolve`). ``robot_path`` and ``scene_path`` are base files a
        command line may name (tasks that have none refuse them).

        Raises:
            ConfigError: naming the file or field and what is allowed.
        """
        if robot_path or scene_path:
            raise UsageError(f"--robot-config and --scene-config configure another task's world; task {self.name} "
                             "takes its configuration from its specification")
        return None

    def episode(self, spec: EpisodeSpec, resolved: Any, *, progress: Callable[[str], None] | None = None,
                observer: EpisodeObserver | None = None) -> Episode:
        """The :class:`~excavsim.loop.episode.Episode` of ``spec`` (not yet reset)."""
        raise NotImplementedError(f"task {self.name} makes no episode")

    def digs(self, spec: EpisodeSpec) -> Any:
        """The dig source of ``spec``'s episode (None: the task's own default)."""
        return None

    def dig_source(self, kind: str, *args, **kwargs) -> Any:
        """The dig source ``kind`` of :attr:`dig_sources`, made with ``args`` and ``kwargs``.

        Raises:
            ConfigError: the task has no dig source ``kind`` (the message lists them).
        """
        if kind not in self.dig_sources:
            raise ConfigError(f"task {self.name} has no dig source {kind!r}; allowed: "
                              f"{', '.join(self.dig_sources) or 'none'}")
        return load_entry(self.dig_sources[kind])(*args, **kwargs)

    def as_mapping(self, field: str, value: Any, data: Mapping[str, Any]) -> dict[str, Any] | None:
        """The task's field ``field``, given as ``value`` (a name: a trench's goal), as the mapping it stands for,
        so that a campaign's dotted grid key can change one of its fields (``goal.depth_m``); ``data`` is the
        rest of the specification. None: the field takes a single value."""
        return None

    def describe(self, spec: EpisodeSpec, resolved: Any) -> str:
        """What an episode of ``spec`` is, in a few words (the first line of ``excavsim run``)."""
        budget = f", {spec.dig_budget} {self.budget} at most" if self.budget else ""
        return f"task {self.name}, machine {spec.machine_name}{budget}, seed {spec.seed}"

    # -- its results ------------------------------------------------------------------------------------
    def summary(self, result: Any) -> dict[str, Any]:
        """The episode's metrics as a flat dict of JSON numbers and strings (a campaign row; the sample
        ``regress`` judges): ``end`` and ``reason`` at least."""
        raise NotImplementedError(f"task {self.name} has no summary")

    def dig_rows(self, result: Any) -> list[dict[str, Any]]:
        """One JSON-ready row per dig (or pass, or trial) of the episode."""
        return []

    def progress_text(self, summary: Mapping[str, Any]) -> str:
        """The summary in a few words, for the progress lines of ``campaign`` and ``regress``."""
        return f"ended {summary.get('end', '?')}"

    def format_run(self, result: Any) -> str:
        """The episode's result as ``excavsim run`` prints it."""
        s = self.summary(result)
        return f"ended {s.get('end')}: {s.get('reason', '')}"

    # -- its other faces ---------------------------------------------------------------------------------
    def recorder(self, path: str | None, *, live: str | None = None) -> EpisodeObserver:
        """The observer that records an episode of the task to the Rerun file ``path`` and/or streams it to the
        viewer at ``live`` (a gRPC URL: the caller starts or finds the viewer, excavsim.record.live).

        Raises:
            UsageError: the task cannot record (the default).
        """
        raise UsageError(f"task {self.name} has no recorder")

    @property
    def can_record(self) -> bool:
        """Whether the task has a recorder (its plug-in overrides :meth:`recorder`)."""
        return type(self).recorder is not TaskPlugin.recorder

    def run_outputs(self, spec: EpisodeSpec, resolved: Any, *, save_maps: str | None = None,
                    timing: bool = False) -> tuple[EpisodeObserver | None, Callable[[Callable[[str], None]], None]]:
        """The observers of ``excavsim run``'s optional outputs (:attr:`outputs`), and what to say after
        the episode. The default supports none of them."""
        return None, lambda say: None

    def add_commands(self, sub: Any) -> None:
        """Add the task's own subcommands to the ``excavsim`` command (none by default)."""

    def warm_up(self, say: Callable[[str], None]) -> None:
        """Compile (or load from numba's cache) the kernels the task's episodes use (``excavsim warmup``)."""


def load_entry(entry: str) -> Any:
    """The object an entry point ``module:attr`` names, imported now.

    Raises:
        ConfigError: the module cannot be imported or has no such attribute (naming the entry).
    """
    import importlib

    module, _, attr = entry.partition(":")
    try:
        obj = importlib.import_module(module)
        for part in attr.split(".") if attr else ():
            obj = getattr(obj, part)
    except (ImportError, AttributeError) as exc:
        raise ConfigError(f"cannot load {entry!r} ({exc}); allowed: an importable module:attribute") from None
    return obj
