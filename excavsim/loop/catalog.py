"""The tasks the platform runs, by name: the one list of tasks.

Every task is a plug-in (:class:`~excavsim.loop.plugin.TaskPlugin`) in its own folder, named here by
one line, ``name: "module:Class"``, or by a third-party distribution through an entry point of the
group :data:`ENTRY_POINT_GROUP`::

    # pyproject.toml of another package
    [project.entry-points."excavsim.tasks"]
    my_task = "my_package.my_task.plugin:MyTask"

or at run time with :func:`register`. The platform imports a plug-in's module only when it is asked
for (the CLI and ``validate`` ask for all of them), so ``loop`` stays below the tasks it runs (the
layer contract of ``pyproject.toml``), as Gymnasium's registry names environments by entry point.
Nothing else in the package says a task's name: the specification, the campaign, ``regress``,
``validate``, the CLI and the environments ask the plug-ins (``tests/test_layout.py`` holds them to it).
"""

from __future__ import annotations

import importlib.metadata
import re
from collections.abc import Callable

from excavsim.errors import ConfigError, shorten
from excavsim.loop.plugin import TaskPlugin, load_entry

TASKS: dict[str, str] = {
    "trench": "excavsim.tasks.trench.plugin:Trench",  # a trench goal dug by the T3 or an excavator (Singh 1995 §7.2)
    "pile_loading": "excavsim.tasks.pile_loading.plugin:PileLoading",  # the loader or shovel loads from a pile (Singh 1995 §7.2.1)
    "dump_trial": "excavsim.tasks.dump_trial.plugin:DumpTrial",  # one dig-swing-dump trial of Rowe's script (Rowe 1997 §6.2)
    "truck_loading": "excavsim.tasks.truck_loading.plugin:TruckLoading",  # a truck loaded to full (Rowe 1997 §4, §6)
}
"""The package's own tasks: name -> the entry point of its plug-in class."""
DEFAULT_TASK = "trench"
"""The task of a specification that names none."""
RENAMED = {"load": "pile_loading", "truck": "dump_trial"}
"""Old task names -> the new ones (refused with the new name in the message)."""
ENTRY_POINT_GROUP = "excavsim.tasks"
"""The entry-point group through which other distributions register their tasks."""

_NAME = re.compile(r"[a-z][a-z0-9_]{0,39}")
_added: dict[str, str | TaskPlugin] = {}  # registered at run time (register) or found by entry point
_loaded: dict[str, TaskPlugin] = {}
_scanned = False


def register(plugin: type[TaskPlugin] | TaskPlugin | str, name: str | None = None) -> str:
    """Register a task at run time: a :class:`~excavsim.loop.plugin.TaskPlugin` (class or instance) or
    the entry point ``module:Class`` of one (then ``name`` is required). Returns its name.

    Raises:
        ConfigError: the name is malformed or taken by another task.
    """
    if isinstance(plugin, str):
        if name is None:
            raise ConfigError(f"register({plugin!r}): an entry point needs the task's name")
        entry: str | TaskPlugin = plugin
    else:
        entry = plugin() if isinstance(plugin, type) else plugin
        name = name or entry.name
    _check_name(name)
    taken = TASKS.get(name) or _added.get(name)
    if taken is not None and taken != entry and not (isinstance(taken, TaskPlugin) and type(taken) is type(entry)):
        raise ConfigError(f"task {name!r} is registered already ({_describe(taken)}); choose another name")
    _added[name] = entry
    _loaded.pop(name, None)
    return name


def unregister(name: str) -> None:
    """Forget a task registered with :func:`register` (tests; the package's own tasks stay)."""
    _added.pop(name, None)
    _loaded.pop(name, None)


def names() -> tuple[str, ...]:
    """Every registered task's name: the package's own, then those of other distributions and of :func:`register`."""
    _scan_entry_points()
    return (*TASKS, *(n for n in _added if n not in TASKS))


def plugin(name: str) -> TaskPlugin:
    """The plug-in of the task registered as ``name``.

    Raises:
        ConfigError: ``name`` is not a registered task (an old name: naming the new one; else the
            message lists the registered ones), or its plug-in cannot be loaded.
    """
    if name in _loaded:
        return _loaded[name]
    _scan_entry_points()
    entry = TASKS.get(name) if name in TASKS else _added.get(name)
    if entry is None:
        if name in RENAMED:
            raise ConfigError(f"task {name!r} is now called {RENAMED[name]!r}; write task: {RENAMED[name]}")
        raise ConfigError(f"unknown task {shorten(repr(name))}; registered here: {', '.join(names())}")
    obj = entry if isinstance(entry, TaskPlugin) else load_entry(entry)
    found = obj() if isinstance(obj, type) and issubclass(obj, TaskPlugin) else obj
    if not isinstance(found, TaskPlugin):
        raise ConfigError(f"task {name!r}: {_describe(entry)} is not a TaskPlugin (excavsim.loop.plugin)")
    if found.name != name:
        raise ConfigError(f"task {name!r}: its plug-in calls itself {found.name!r}; the names must agree")
    _loaded[name] = found
    return found


def plugins() -> dict[str, TaskPlugin]:
    """Every registered task's plug-in, by name (each imported now)."""
    return {n: plugin(n) for n in names()}


def progress_text(summary: dict, task: str) -> str:
    """An episode's summary in a few words, in its task's (``task``) words."""
    return plugin(task).progress_text(summary)


def dig_source(task: str, kind: str, *args, **kwargs):
    """A dig source of task ``task`` by name (its plug-in's ``dig_sources``), made with ``args`` and
    ``kwargs``. Lets a caller that stands beside the tasks (an application: the calibration's digs)
    choose the digs of an episode.

    Raises:
        ConfigError: ``task`` is not registered, or has no dig source ``kind`` (the message lists them).
    """
    return plugin(task).dig_source(kind, *args, **kwargs)


def summary_number(s: dict) -> Callable[..., str]:
    """``num(key, scale=1, fmt=".0f")``: the summary's ``key`` times ``scale`` in ``fmt``, or ``?`` when it is
    missing or not a number (a task's ``progress_text`` uses it; an older summary may lack a key)."""
    def num(key: str, scale: float = 1.0, fmt: str = ".0f") -> str:
        v = s.get(key)
        return format(scale * v, fmt) if isinstance(v, int | float) else "?"
    return num


def _check_name(name: str) -> None:
    if not isinstance(name, str) or not _NAME.fullmatch(name):
        raise ConfigError(f"task name {shorten(repr(name))}: allowed lowercase letters, digits and _, starting "
                          "with a letter, at most 40 characters")


def _describe(entry: str | TaskPlugin) -> str:
    return entry if isinstance(entry, str) else f"{type(entry).__module__}.{type(entry).__qualname__}"


def _scan_entry_points() -> None:
    """Add the tasks other distributions register through :data:`ENTRY_POINT_GROUP` (once)."""
    global _scanned
    if _scanned:
        return
    _scanned = True
    for ep in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP):
        if ep.name not in TASKS and ep.name not in _added and _NAME.fullmatch(ep.name):
            _added[ep.name] = ep.value
