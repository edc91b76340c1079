"""The task catalog: the one list of tasks, their plug-ins imported when asked for, tasks added at run time."""

from __future__ import annotations

import pytest

from excavsim.errors import ConfigError
from excavsim.loop import catalog
from excavsim.loop.plugin import TaskPlugin


def test_every_registered_task_has_a_plugin_that_names_it_and_its_machines_and_options():
    for name, plugin in catalog.plugins().items():
        assert isinstance(plugin, TaskPlugin) and plugin.name == name
        assert plugin.machines and all(isinstance(m, str) for m in plugin.machines)
        assert plugin.title and plugin.options.model_fields is not None
        for key, metric in plugin.metrics.items():
            assert metric.better in ("higher", "lower") and metric.abs_tol >= 0, (name, key)


def test_an_unknown_task_is_refused_naming_the_registered_ones_and_an_old_name_names_the_new_one():
    with pytest.raises(ConfigError, match="unknown task 'dig'.*pile_loading"):
        catalog.plugin("dig")
    for old, new in catalog.RENAMED.items():
        with pytest.raises(ConfigError, match=f"'{old}' is now called '{new}'"):
            catalog.plugin(old)


def test_a_dig_source_is_made_by_its_tasks_name_and_an_unknown_one_is_refused():
    from excavsim.loop.digs import DigSource

    scripted = catalog.dig_source(catalog.DEFAULT_TASK, "scripted", [(2.2, 0.7, 0.2, 0.4)])
    assert isinstance(scripted, DigSource) and len(scripted.actions) == 1
    with pytest.raises(ConfigError, match="no dig source 'tuner'.*planner, random, scripted"):
        catalog.dig_source(catalog.DEFAULT_TASK, "tuner")


class _Tiny(TaskPlugin):
    name = "tiny_test_task"
    title = "a task that exists only in this test"
    machines = ("t3",)


def test_a_task_registered_at_run_time_is_listed_and_a_taken_or_malformed_name_is_refused():
    try:
        assert catalog.register(_Tiny) == "tiny_test_task"
        assert "tiny_test_task" in catalog.names()
        assert isinstance(catalog.plugin("tiny_test_task"), _Tiny)
        assert catalog.register(_Tiny) == "tiny_test_task"  # the same plug-in again: no harm

        class Other(_Tiny):
            pass

        with pytest.raises(ConfigError, match="registered already"):
            catalog.register(Other)
        with pytest.raises(ConfigError, match="registered already"):
            catalog.register("somewhere:Else", catalog.DEFAULT_TASK)
        with pytest.raises(ConfigError, match="lowercase letters"):
            catalog.register(_Tiny, "Bad Name")
    finally:
        catalog.unregister("tiny_test_task")
    assert "tiny_test_task" not in catalog.names()


def test_an_entry_point_that_is_no_plugin_or_calls_itself_otherwise_is_refused():
    try:
        catalog.register("excavsim.loop.catalog:names", "not_a_plugin")
        with pytest.raises(ConfigError, match="is not a TaskPlugin"):
            catalog.plugin("not_a_plugin")
        catalog.register(_Tiny, "another_name")
        with pytest.raises(ConfigError, match="calls itself 'tiny_test_task'"):
            catalog.plugin("another_name")
        catalog.register("excavsim.no_such_module:Task", "missing_module")
        with pytest.raises(ConfigError, match="cannot load 'excavsim.no_such_module:Task'"):
            catalog.plugin("missing_module")
    finally:
        for name in ("not_a_plugin", "another_name", "missing_module"):
            catalog.unregister(name)
