"""A task from outside the package registers through the entry-point group ``excavsim.tasks`` (the catalog's
``ENTRY_POINT_GROUP``), as another distribution's would: no line of excavsim names it, yet ``excavsim tasks``
lists it and ``excavsim run`` runs a specification of it.

The distribution is written to a temporary folder: a module with a :class:`~excavsim.loop.plugin.TaskPlugin`
subclass (its episode the made-up heap task of ``tests/loop/test_made_up_task.py``: no MuJoCo) and a
``heap_tasks-0.1.dist-info`` folder whose ``entry_points.txt`` names it; the commands run in a fresh interpreter
with that folder on ``PYTHONPATH``, so :mod:`importlib.metadata` finds it as if it were installed.
"""

from __future__ import annotations

import os
import subprocess
import sys

from excavsim import constants
from excavsim.loop.catalog import ENTRY_POINT_GROUP

PLUGIN = '''
from pydantic import Field

from excavsim.config import StrictModel
from excavsim.loop.episode import Episode
from excavsim.loop.plugin import TaskPlugin


class HeapOptions(StrictModel):
    units: int = Field(default=5, ge=1, description="units of soil in the heap")


class Heap(TaskPlugin):
    name = "heap"
    title = "take a heap of soil units away (a task of another distribution)"
    machines = ("t3",)
    options = HeapOptions

    def episode(self, spec, resolved, *, progress=None, observer=None):
        from tests.loop.test_made_up_task import HeapTask

        return Episode(HeapTask(units=spec.options.units), dig_budget=spec.dig_budget, progress=progress,
                       observer=observer)

    def summary(self, result):
        return {"task": self.name, "end": result["end"], "reason": result["reason"], "digs": len(result["taken"]),
                "left": result["left"]}
'''


def excavsim(*args: str, site, work) -> subprocess.CompletedProcess:
    """``python -m excavsim.cli ARGS`` in a fresh interpreter in the folder ``work``, with the folder ``site`` (a
    distribution's, or None) and the repository on PYTHONPATH."""
    path = [str(p) for p in (site, constants.REPO_ROOT) if p is not None]
    return subprocess.run([sys.executable, "-m", "excavsim.cli", *args], capture_output=True, text=True, cwd=work,
                          env={**os.environ, "PYTHONPATH": os.pathsep.join(path)}, timeout=300)


def test_a_task_of_another_distribution_is_listed_and_runs_through_the_entry_point_group(tmp_path):
    site, work = tmp_path / "site", tmp_path / "work"
    info = site / "heap_tasks-0.1.dist-info"
    info.mkdir(parents=True)
    work.mkdir()
    (site / "heap_tasks.py").write_text(PLUGIN)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: heap-tasks\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(f"[{ENTRY_POINT_GROUP}]\nheap = heap_tasks:Heap\n")
    (work / "heap.yaml").write_text("name: heap\ntask: heap\nunits: 5\ndig_budget: 10\n")

    listed = excavsim("tasks", site=site, work=work)
    assert listed.returncode == 0, listed.stderr
    assert "heap: take a heap of soil units away (a task of another distribution)" in listed.stdout
    assert "its fields: units" in listed.stdout

    ran = excavsim("run", "heap.yaml", site=site, work=work)
    assert ran.returncode == 0, ran.stderr
    lines = ran.stdout.splitlines()
    assert lines[0] == "excavsim run: task heap, machine t3, 10 digs at most, seed 0"
    assert "scan 1: 5 units" in lines and "scan 4: 0 units" in lines and lines[-1] == "ended done: the heap is gone"

    # without the distribution on the path the task is unknown, and the message lists the registered ones
    alone = excavsim("run", "heap.yaml", site=None, work=work)
    assert alone.returncode == 2 and "unknown task 'heap'" in alone.stderr and "pit_digging" in alone.stderr
