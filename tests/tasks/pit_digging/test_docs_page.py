"""The "Write your own task" page keeps up with the pit-digging task: every code block it includes from the files
finds its code, and its table of measured digs is the golden scenario's baseline. (``tests/test_docs.py`` runs
its Python blocks and parses its commands; the docs build fails on an include that finds nothing, in CI.)"""

from __future__ import annotations

import ast
import json
import re

from excavsim import constants

PAGE = constants.REPO_ROOT / "docs" / "tasks" / "write-your-own-task.md"
INCLUDE = re.compile(r"^```\{literalinclude\} (\S+)\n((?::[\w-]+: .*\n)*)", re.M)


def test_every_code_block_the_page_includes_finds_its_code():
    includes = INCLUDE.findall(PAGE.read_text(encoding="utf-8"))
    assert len(includes) >= 10
    for path, options in includes:
        file = (PAGE.parent / path).resolve()
        assert file.is_file(), path
        opts = dict(re.findall(r":([\w-]+): (.*)", options))
        if "pyobject" in opts:
            names = {n.name for n in ast.parse(file.read_text()).body if isinstance(n, ast.ClassDef | ast.FunctionDef)}
            assert opts["pyobject"] in names, f"{path} defines no {opts['pyobject']}"
        for key in ("start-at", "end-at"):
            if key in opts:
                assert opts[key].strip("'") in file.read_text(), f"{path}: no {opts[key]}"


def test_the_pages_table_of_measured_digs_is_the_golden_scenarios_baseline():
    baseline = json.loads((constants.CONFIGS_DIR / "regress" / "baseline.json").read_text())["scenarios"]["pit_small"]
    rows = re.findall(r"^\| (\d) \| (\d+) \| (\d+) % \| ([\d.]+) cm \| ([\d.]+) cm \| (\w+) \|$", PAGE.read_text(), re.M)
    m = baseline["metrics"]
    assert [int(r[0]) for r in rows] == baseline["seeds"]
    for i, (_, digs, removed, over, under, end) in enumerate(rows):
        assert int(digs) == m["digs"]["values"][i] and end == baseline["end"][i]
        assert int(removed) == round(100 * m["removed_fraction"]["values"][i])
        assert (float(over), float(under)) == (round(m["overdig_max_cm"]["values"][i], 1),
                                                round(m["underdig_rms_cm"]["values"][i], 1))
