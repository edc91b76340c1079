"""The environments' machinery names no task and no machine (issue 41): environments are what a task
contributes from its own folder (its plug-in's ``environments``), and the joint level's defaults come from
the id's keywords or the machine registry.

Each module of ``excavsim/envs/`` is parsed: no import of ``excavsim.tasks`` (the layer contract of
pyproject.toml holds the direction; this holds the name), and no string constant of the code (its
documentation, the bare strings that are docstrings, aside) holding a task's or a machine's name as a word
(``.``, ``/``, ``:`` and ``_`` separate words, so that an entry point ``excavsim.tasks.<task>.x:Y`` counts).
"""

from __future__ import annotations

import ast
import pathlib
import re

import pytest

from excavsim import constants
from excavsim.loop import catalog
from excavsim.robot.machine import MACHINES

ENVS = constants.PACKAGE_ROOT / "envs"


def forbidden_names() -> set[str]:
    """Every registered task's name and every machine's: the registry's and those the tasks run."""
    names = set(catalog.names()) | set(MACHINES)
    for plugin in catalog.plugins().values():
        names |= set(plugin.machines)
    return names


def _documentation(tree: ast.AST) -> set[int]:
    """The ids of the string constants that are bare expression statements (docstrings, attribute docs)."""
    return {id(node.value) for node in ast.walk(tree)
            if isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant) and isinstance(node.value.value, str)}


def offences(source: str, names: set[str]) -> list[str]:
    """What in module ``source`` names a task or a machine: imports of ``excavsim.tasks`` and string constants
    holding one of ``names`` as a word, each as ``line: what``."""
    tree = ast.parse(source)
    docs = _documentation(tree)
    word = re.compile(r"(?<![A-Za-z0-9])(" + "|".join(map(re.escape, sorted(names, key=len, reverse=True)))
                      + r")(?![A-Za-z0-9])")
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [f"{node.lineno}: import {a.name}" for a in node.names if a.name.startswith("excavsim.tasks")]
        elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith("excavsim.tasks"):
            found.append(f"{node.lineno}: from {node.module} import ...")
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docs:
            hit = word.search(node.value)
            if hit:
                found.append(f"{node.lineno}: {hit.group(1)!r} in {node.value!r}")
    return found


def test_the_names_are_the_catalogs_and_the_registrys():
    names = forbidden_names()
    assert {"trench", "pile_loading", "dump_trial", "truck_loading"} <= names
    assert {"t3", "tb035", "excavator_25t", "loader", "shovel"} <= names


@pytest.mark.parametrize("path", sorted(ENVS.glob("*.py")), ids=lambda p: p.name)
def test_no_module_of_the_environments_machinery_names_a_task_or_a_machine(path: pathlib.Path):
    assert offences(path.read_text(), forbidden_names()) == []


def test_the_check_finds_a_planted_name_and_import_and_spares_documentation():
    names = forbidden_names()
    source = '''"""A docstring may name the trench and the tb035 as examples."""
import excavsim.tasks.trench.plugin
from excavsim.tasks.pile_loading import envs
GOAL = "excavsim.tasks.trench.envs.joint:JointTrench"
DEFAULTS = {"machine": "tb035"}
MESSAGE = f"no region for {name}: allowed excavator_25t"
DOC = """the trenching machines, their loaders"""  # words that contain a name are not it
"""An attribute's documentation may name the shovel."""
'''
    found = offences(source, names)
    assert [line.split(":")[0] for line in found] == ["2", "3", "4", "5", "6"], found
