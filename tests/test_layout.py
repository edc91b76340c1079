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
])
def test_a_planted_import_breaks_its_contract(tmp_path, module, planted, contract):
    """A copy of the package with one import that the architecture forbids fails the check."""
    shutil.copytree(constants.PACKAGE_ROOT, tmp_path / "excavsim", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(PYPROJECT, tmp_path / "pyproject.toml")
    target = tmp_path / "excavsim" / module
    target.write_text(target.read_text() + f"\n{planted}  # planted by the test\n")
    out = lint(tmp_path)
    assert out.returncode != 0, out.stdout
    # import-linter wraps long contract names: read its report as one line, each verdict after its name
    report = " ".join(out.stdout.split())
    broken = [part.rsplit("KEPT", 1)[-1] for part in report.split("BROKEN")[:-1]]
    assert any(contract in part for part in broken), out.stdout
