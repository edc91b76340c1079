"""A task is one folder: nothing outside a task's folder and the catalog says its name, and the platform,
``validate``, the CLI, the studies and the configuration models say no machine's name either.

A name is said by a string constant equal to it (``task == "trench"``, ``{"t3": ...}``, ``machine="loader"``), by a
string naming the task's package (``"excavsim.tasks.trench.task:run"``) or by an import of the task's package. Prose
(docstrings, comments, messages that mention a machine in a sentence) is not a name.
"""

from __future__ import annotations

import ast
import pathlib

import pytest

from excavsim import constants
from excavsim.loop import catalog

PACKAGE = constants.PACKAGE_ROOT
PLATFORM = ("loop", "validate.py", "cli", "studies", "config")
"""What names no task and no machine at all (the catalog aside)."""
CATALOG = PACKAGE / "loop" / "catalog.py"


def _modules(*places: str) -> list[pathlib.Path]:
    out = []
    for place in places:
        path = PACKAGE / place
        out += sorted(path.rglob("*.py")) if path.is_dir() else [path]
    return out


def _folder(task: str) -> pathlib.Path:
    """The task's folder: where its plug-in's module lies."""
    return pathlib.Path(type(catalog.plugin(task)).__module__.replace(".", "/")).parent


def said(path: pathlib.Path, names: set[str]) -> list[str]:
    """Where the module ``path`` says one of ``names``: ``line: name (how)``."""
    tree = ast.parse(path.read_text(), filename=str(path))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            if node.value in names:
                found.append(f"{node.lineno}: {node.value!r}")
            found += [f"{node.lineno}: {node.value!r} (its package)" for n in names
                      if f"excavsim.tasks.{n}." in node.value or node.value.endswith(f"excavsim.tasks.{n}")]
        elif isinstance(node, ast.ImportFrom) and node.module:
            found += [f"{node.lineno}: import {node.module}" for n in names
                      if node.module == f"excavsim.tasks.{n}" or node.module.startswith(f"excavsim.tasks.{n}.")]
        elif isinstance(node, ast.Import):
            found += [f"{node.lineno}: import {a.name}" for a in node.names for n in names
                      if a.name == f"excavsim.tasks.{n}" or a.name.startswith(f"excavsim.tasks.{n}.")]
    return found


def test_the_checker_finds_a_name_said_every_way(tmp_path):
    module = tmp_path / "m.py"
    module.write_text('"""Docstring mentioning trench."""\nimport excavsim.tasks.trench.task\n'
                      'from excavsim.tasks.trench import plugin\nX = {"trench": 1}\n'
                      'Y = "excavsim.tasks.trench.plugin:Trench"\n# trench in a comment\nZ = "a trench"\n')
    assert sorted(f.split(":")[0] for f in said(module, {"trench"})) == ["2", "3", "4", "5"]


@pytest.mark.parametrize("path", _modules(*PLATFORM), ids=lambda p: str(p.relative_to(PACKAGE)))
def test_the_platform_names_no_task_and_no_machine(path):
    if path == CATALOG:
        return
    tasks = set(catalog.names())
    machines = {m for p in catalog.plugins().values() for m in p.machines}
    assert not said(path, tasks | machines), f"{path.relative_to(PACKAGE)} says " + "; ".join(said(path, tasks | machines))


@pytest.mark.parametrize("task", list(catalog.TASKS))
def test_a_tasks_name_appears_only_in_its_folder_and_the_catalog(task):
    folder = PACKAGE.parent / _folder(task)
    others = [p for p in _modules(".") if p != CATALOG and folder not in p.parents]
    found = {str(p.relative_to(PACKAGE)): said(p, {task}) for p in others}
    found = {k: v for k, v in found.items() if v}
    assert not found, f"task {task}'s name outside its folder: {found}"
