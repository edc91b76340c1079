"""The architecture as a test: the import-linter contracts hold, and they catch an arrow that runs upward."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tomllib

import pytest

from excavsim import constants

PYPROJECT = constants.REPO_ROOT / "pyproject.toml"
LINT = shutil.which("lint-imports", path=os.path.dirname(sys.executable))


def contracts() -> list[dict]:
    return tomllib.loads(PYPROJECT.read_text())["tool"]["importlinter"]["contracts"]


def lint(root, *extra) -> subprocess.CompletedProcess:
    assert LINT is not None, "lint-imports (import-linter, in the dev extra) is missing: pip install -e '.[dev]'"
    env = {**os.environ, "PYTHONPATH": str(root)}
    return subprocess.run([LINT, "--no-logo", "--no-cache", *extra], cwd=root, env=env, capture_output=True,
                          text=True, timeout=120)


def test_the_contracts_ignore_no_import():
    assert contracts(), "pyproject.toml has no import-linter contracts"
    for c in contracts():
        assert "ignore_imports" not in c, f"contract {c['name']!r} ignores imports"


def test_the_package_keeps_every_contract():
    out = lint(constants.REPO_ROOT)
    assert out.returncode == 0, out.stdout + out.stderr
    assert f"Contracts: {len(contracts())} kept, 0 broken." in out.stdout


@pytest.mark.parametrize(("module", "planted", "contract"), [
    ("planning/__init__.py", "import excavsim.world.simulation", "never imports the world"),
    ("world/__init__.py", "import excavsim.planning.predictor", "Layers"),
    ("learning/__init__.py", "import mujoco", "no MuJoCo"),
    ("loop/digs.py", "import excavsim.loop.episode", "No import cycles"),
    ("loop/episode.py", "import excavsim.tasks.trench.task", "Layers"),
    ("apps/calibrate/digs.py", "import excavsim.tasks.trench.digs", "Layers"),
    ("tasks/trench/task.py", "import excavsim.tasks.dump_trial.trial", "No task imports another"),
    ("loop/scenario.py", "import excavsim.studies.campaign.runner", "Layers"),
    ("tasks/dump_trial/trial.py", "import excavsim.tasks.pile_loading.planar", "No task imports another"),
    ("apps/calibrate/fit.py", "import excavsim.apps.playback.driver", "No application imports another"),
    ("studies/bench.py", "import excavsim.studies.regress.suite", "No study imports another"),
    # inside a task's folder: its mind side never reaches the truth, its world side never the mind
    ("tasks/pile_loading/mind/planner.py", "import excavsim.world.soil", "A task's mind"),
    ("tasks/pile_loading/mind/script.py", "import excavsim.tasks.pile_loading.world.scene", "A task's mind"),
    ("tasks/truck_loading/mind/autodig.py", "import excavsim.tasks.truck_loading.world.truck", "A task's mind"),
    ("tasks/truck_loading/mind/planner.py", "import excavsim.tasks.truck_loading.task", "A task's mind"),
    ("tasks/trench/mind/fallback.py", "import mujoco", "A task's mind"),
    ("tasks/trench/mind/fallback.py", "import excavsim.rig.core", "A task's mind"),
    ("tasks/pile_loading/world/pile2d.py", "import excavsim.tasks.pile_loading.mind.planner", "A task's world"),
    ("tasks/pile_loading/world/scene.py", "import excavsim.planning.search", "A task's world"),
    ("tasks/truck_loading/world/truck.py", "import excavsim.tasks.truck_loading.mind.autodig", "A task's world"),
    ("tasks/truck_loading/world/truck.py", "import excavsim.execution.rowe_script", "A task's world"),
])
def test_a_planted_import_breaks_its_contract(tmp_path, module, planted, contract):
    """A copy of the package with one import that the architecture forbids fails the check."""
    copy = package_copy(tmp_path)
    target = copy / module
    target.write_text(target.read_text() + f"\n{planted}  # planted by the test\n")
    assert_broken(lint(tmp_path), contract)


def package_copy(tmp_path):
    """A copy of the package and its pyproject.toml under ``tmp_path``; the copy's package folder."""
    shutil.copytree(constants.PACKAGE_ROOT, tmp_path / "excavsim", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(PYPROJECT, tmp_path / "pyproject.toml")
    return tmp_path / "excavsim"


def assert_broken(out: subprocess.CompletedProcess, contract: str) -> None:
    """The check failed, and ``contract`` (part of its name) is among the broken contracts."""
    assert out.returncode != 0, out.stdout
    # import-linter wraps long contract names: read its report as one line, each verdict after its name
    report = " ".join(out.stdout.split())
    broken = [part.rsplit("KEPT", 1)[-1] for part in report.split("BROKEN")[:-1]]
    assert any(contract in part for part in broken), out.stdout


@pytest.mark.parametrize(("module", "planted", "contract"), [
    ("mind/plan.py", "import excavsim.world.terrain", "A task's mind"),
    ("mind/plan.py", "import excavsim.tasks.levelling.world.mound", "A task's mind"),
    ("world/mound.py", "import excavsim.tasks.levelling.mind.plan", "A task's world"),
    ("world/mound.py", "import excavsim.sensing.elevation", "A task's world"),
    ("task.py", "import excavsim.tasks.trench.task", "No task imports another"),
])
def test_a_new_task_folder_is_held_to_the_rules(tmp_path, module, planted, contract):
    """The contracts are written over ``excavsim.tasks.*``: a task folder nobody listed keeps them too."""
    folder = package_copy(tmp_path) / "tasks" / "levelling"
    for sub in ("", "mind", "world"):
        (folder / sub).mkdir(exist_ok=True)
        (folder / sub / "__init__.py").write_text('"""A made-up task (planted by the test)."""\n')
    (folder / "mind" / "plan.py").write_text("import numpy\n")
    (folder / "world" / "mound.py").write_text("import mujoco\nimport excavsim.world.terrain\n")
    (folder / "task.py").write_text("import excavsim.tasks.levelling.mind.plan\n"
                                    "import excavsim.tasks.levelling.world.mound\n")
    assert lint(tmp_path).returncode == 0, "the made-up task breaks a contract before anything is planted"
    target = folder / module
    target.write_text(target.read_text() + f"{planted}  # planted by the test\n")
    assert_broken(lint(tmp_path), contract)
