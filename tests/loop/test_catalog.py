"""The task catalog: tasks named by entry point, imported when an episode of them is made."""

from __future__ import annotations

import pytest

from excavsim.errors import ConfigError
from excavsim.loop.catalog import TASKS, task_class


def test_every_registered_task_imports_and_has_the_task_hooks():
    for name in TASKS:
        cls = task_class(name)
        for hook in ("reset",):
            assert callable(getattr(cls, hook, None)), f"{name}: {cls.__name__} has no {hook}"


def test_an_unknown_task_is_refused_naming_the_registered_ones():
    with pytest.raises(ConfigError, match="unknown task 'dig'.*load"):
        task_class("dig")


def test_a_dig_source_is_made_by_its_tasks_name_and_an_unknown_one_is_refused():
    from excavsim.loop.catalog import dig_source
    from excavsim.loop.digs import DigSource

    scripted = dig_source("trench", "scripted", [(2.2, 0.7, 0.2, 0.4)])
    assert isinstance(scripted, DigSource) and len(scripted.actions) == 1
    with pytest.raises(ConfigError, match="no dig source 'tuner'.*planner, random, scripted"):
        dig_source("trench", "tuner")
