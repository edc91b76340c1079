"""The tasks the platform composes, by name.

Every task lives in its home under ``excavsim.tasks`` and is named here by its entry point,
``module:Class``.
The platform imports a task's module only when an episode of it is made, so ``loop`` stays below the
tasks it runs (the layer contract of ``pyproject.toml``), as Gymnasium's registry names environments
by entry point. A new task adds one line here and a ``task:`` value of the episode specification.
"""

from __future__ import annotations

import importlib

from excavsim.errors import ConfigError

TASKS: dict[str, str] = {
    "trench": "excavsim.tasks.trench.task:TrenchTask",  # a trench goal dug by the T3 (Singh 1995 §7.2, Fig. 107)
    "load": "excavsim.tasks.load.task:LoadTask",  # loading from a pile in MuJoCo (Singh 1995 §7.2.1)
    "truck": "excavsim.tasks.truck.episode:TruckTrial",  # one truck-loading trial on the T3 (Rowe 1997 §6.2)
    # a truck loaded to full, pass after pass, by the 25 t excavator (Rowe 1997 §4, §6)
    "truck_loading": "excavsim.tasks.truck_loading.task:TruckLoadingTask",
}


def summary_number(s: dict):
    """``num(key, scale=1, fmt=".0f")``: the summary's ``key`` times ``scale`` in ``fmt``, or ``?`` when it is
    missing or not a number (a task's ``progress_text`` uses it; an older summary may lack a key)."""
    def num(key: str, scale: float = 1.0, fmt: str = ".0f") -> str:
        v = s.get(key)
        return format(scale * v, fmt) if isinstance(v, int | float) else "?"
    return num


def progress_text(summary: dict) -> str:
    """An episode's summary in a few words, by its task's module (``task`` absent: trench)."""
    return task_module(summary.get("task") or "trench").progress_text(summary)


def task_module(name: str):
    """The module of the task registered as ``name`` (it also defines ``format_run``, the task's table, and
    may define ``summary`` and ``dig_rows``, its campaign row and per-dig rows, ``episode_recorder``, its
    Rerun recorder, and ``DIG_SOURCES``, its dig sources by name: :func:`dig_source`, and ``progress_text``, its summary in a
    few words).

    Raises:
        ConfigError: ``name`` is not a registered task (the message lists them).
    """
    return importlib.import_module(_entry(name)[0])


def _entry(name: str) -> tuple[str, str]:
    try:
        entry = TASKS[name]
    except KeyError:
        raise ConfigError(f"unknown task {name!r}; registered here: {', '.join(TASKS)}") from None
    module, _, attr = entry.partition(":")
    return module, attr


def task_class(name: str) -> type:
    """The task class registered as ``name``.

    Raises:
        ConfigError: ``name`` is not a registered task (the message lists them).
    """
    module, attr = _entry(name)
    return getattr(importlib.import_module(module), attr)


def dig_source(task: str, kind: str, *args, **kwargs):
    """A dig source of task ``task`` by name (its module's ``DIG_SOURCES``), made with ``args`` and
    ``kwargs``: for trenching ``planner``, ``random`` and ``scripted``. Lets a caller that stands
    beside the tasks (an application: the calibration's digs) choose the digs of an episode.

    Raises:
        ConfigError: ``task`` is not registered, or has no dig source ``kind`` (the message lists them).
    """
    sources = getattr(task_module(task), "DIG_SOURCES", {})
    if kind not in sources:
        raise ConfigError(f"task {task} has no dig source {kind!r}; allowed: {', '.join(sources) or 'none'}")
    return sources[kind](*args, **kwargs)
