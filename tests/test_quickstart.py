"""The README's Python quickstart runs as written, and the Python API it starts from holds.

QUICKSTART_SOURCE is the file whose "## Python quickstart" section's first python block is run
verbatim in a fresh interpreter.
"""

from __future__ import annotations

import re
import subprocess
import sys
import tomllib

import excavsim
from excavsim import cli, constants

QUICKSTART_SOURCE = constants.REPO_ROOT / "README.md"
MAX_LINES = 10  # the quickstart's promise: at most ten lines of code


def quickstart_code() -> str:
    text = QUICKSTART_SOURCE.read_text()
    section = text.split("## Python quickstart", 1)
    assert len(section) == 2, f"{QUICKSTART_SOURCE} has no '## Python quickstart' section"
    block = re.search(r"```python\n(.*?)```", section[1], re.S)
    assert block, "the quickstart section has no python block"
    return block.group(1)


def test_the_quickstart_runs_verbatim_in_at_most_ten_lines(tmp_path):
    code = quickstart_code()
    lines = [line for line in code.splitlines() if line.strip() and not line.lstrip().startswith("#")]
    assert len(lines) <= MAX_LINES, f"the quickstart has {len(lines)} lines of code"
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert "ended: " in out.stdout and "removed " in out.stdout  # format_episode's summary
    assert float(out.stdout.strip().splitlines()[-1]) > 0.5  # the removed fraction


def test_import_excavsim_is_light_and_exports_the_common_path_with_docstrings():
    code = "import sys, excavsim; print(sorted(m for m in ('numpy', 'mujoco', 'excavsim.loop') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.stdout.strip() == "[]", out.stdout + out.stderr
    for name in excavsim.__all__:
        value = getattr(excavsim, name)
        assert name == "__version__" or (value.__doc__ or "").strip(), f"excavsim.{name} has no docstring"
    assert set(excavsim.__all__) <= set(dir(excavsim))
    try:
        excavsim.no_such_name
    except AttributeError as exc:
        assert "no_such_name" in str(exc)
    else:
        raise AssertionError("excavsim.no_such_name did not raise AttributeError")


def test_version_matches_the_package_metadata(capsys):
    version = tomllib.loads((constants.REPO_ROOT / "pyproject.toml").read_text())["project"]["version"]
    assert excavsim.__version__ == version
    assert cli.main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"excavsim {version}"
