"""The platform needs no task of its own: its :class:`~excavsim.loop.episode.Episode` runs a made-up task.

The task here is a heap of soil units on a fake world (no MuJoCo, no trench): each dig takes some
units, the map is the heap's count, the task is done when the heap is empty. The tests check what
the episode does for every task, written once: the order of the observers' hooks, the dig budget
(with and without a final scan), the done test, no dig, the world failing while parking, and the
result handed to ``finished`` and returned by ``run``.
"""

from __future__ import annotations

import math
import pathlib
import subprocess
import sys

import pytest

from excavsim.errors import Diverged
from excavsim.loop.digs import Choice
from excavsim.loop.episode import Episode


class HeapWorld:
    """A fake world: a heap of units, a clock, and the step hooks the episode hangs its observer on."""

    def __init__(self, units: int):
        self.units = units
        self.time = 0.0
        self.step_hooks: list = []
        self.wall_deadline = None
        self.fail_next_park = False

    def step(self) -> None:
        self.time += 0.1
        for hook in self.step_hooks:
            hook(self)


class HeapTask:
    """A made-up task implementing the episode's ``Task`` protocol: dig a heap of units away.

    Each dig takes ``take`` units (two control steps of the world); the map is the heap's count;
    the done test is an empty heap. ``choose`` gives no dig once ``refuse_after`` digs were chosen.
    """

    def __init__(self, units: int = 5, take: int = 2, *, final_scan: bool = True, refuse_after: int | None = None):
        self.units, self.take, self.final_scan, self.refuse_after = units, take, final_scan, refuse_after
        self.wall_limit_s = math.inf
        self.calls: list[str] = []

    def reset(self, seed, world=None, digs=None):
        self.world = world or HeapWorld(self.units)
        self.chosen = 0
        self.taken: list[int] = []
        self.calls = [f"reset {seed}"]
        return self.world, "machine"

    def budget_reason(self, budget):
        return f"{budget} digs spent"

    def park(self):
        self.calls.append("park")
        if self.world.fail_next_park:
            raise Diverged("the fake world diverged")

    def scan(self):
        self.calls.append("scan")
        return self.world.units, "exact"

    def assess(self, index, scanned, say):
        say(f"scan {index}: {scanned} units")
        return scanned, (("done", "the heap is gone") if scanned == 0 else None)

    def choose(self, emap):
        self.calls.append("choose")
        if self.refuse_after is not None and self.chosen >= self.refuse_after:
            return Choice(None, reason="no dig wanted")
        self.chosen += 1
        return Choice(min(self.take, emap), note=f"take {min(self.take, emap)}")

    def execute(self, index, choice):
        self.calls.append(f"execute {index}")
        self.world.step()
        self.world.step()
        self.world.units -= choice.dig
        self.taken.append(choice.dig)
        return (choice.dig, self.world.units), None

    def after(self, index, choice, dug, say):
        self.calls.append(f"after {index}")
        return None

    def result(self, end, reason, wall_s):
        return {"end": end, "reason": reason, "taken": list(self.taken), "left": self.world.units,
                "wall_s": wall_s}


class Hooks:
    """An observer of the made-up task: records each hook with its arguments."""

    def __init__(self):
        self.calls: list = []

    def started(self, world, machine):
        self.calls.append(("started", machine))

    def scanned(self, index, emap, detail):
        self.calls.append(("scanned", index, emap))

    def planned(self, index, plan, dig):
        self.calls.append(("planned", index, dig))

    def stepped(self, world):
        self.calls.append(("stepped",))

    def dug(self, index, taken, left):
        self.calls.append(("dug", index, taken, left))

    def finished(self, result):
        self.calls.append(("finished", None if result is None else result["end"]))


def run_heap(**kw):
    """One episode of the made-up task with an observer; (result, hooks, task, progress lines)."""
    budget = kw.pop("dig_budget", 20)
    task, hooks, lines = HeapTask(**kw), Hooks(), []
    ep = Episode(task, dig_budget=budget, observer=hooks, progress=lines.append)
    ep.reset(7)
    return ep.run(), hooks, task, lines, ep


def test_the_done_test_ends_a_made_up_task_and_the_hooks_come_in_order():
    result, hooks, task, lines, ep = run_heap(units=5, take=2)
    assert result == {"end": "done", "reason": "the heap is gone", "taken": [2, 2, 1], "left": 0,
                      "wall_s": result["wall_s"]}
    assert result["wall_s"] >= 0 and ep.result is result and ep.over and ep.digs_done == 3
    stepped = [("stepped",)] * 2
    assert hooks.calls == [("started", "machine"),
                           ("scanned", 1, 5), ("planned", 1, 2), *stepped, ("dug", 1, 2, 3),
                           ("scanned", 2, 3), ("planned", 2, 2), *stepped, ("dug", 2, 2, 1),
                           ("scanned", 3, 1), ("planned", 3, 1), *stepped, ("dug", 3, 1, 0),
                           ("scanned", 4, 0), ("finished", "done")]
    assert task.calls == ["reset 7", "park", "scan", "choose", "execute 1", "after 1",
                          "park", "scan", "choose", "execute 2", "after 2",
                          "park", "scan", "choose", "execute 3", "after 3", "park", "scan"]
    assert lines == ["scan 1: 5 units", "take 2", "scan 2: 3 units", "take 2", "scan 3: 1 units", "take 1",
                     "scan 4: 0 units"]
    assert ep.sim.step_hooks == []  # the observer is unhooked from the world at the end


def test_the_dig_budget_ends_the_episode_after_a_final_scan_or_right_after_the_last_dig():
    result, hooks, task, _, ep = run_heap(units=9, take=2, dig_budget=2)
    assert (result["end"], result["reason"], result["taken"], result["left"]) == ("budget", "2 digs spent", [2, 2], 5)
    assert [c[0] for c in hooks.calls if c[0] != "stepped"] == \
        ["started", "scanned", "planned", "dug", "scanned", "planned", "dug", "scanned", "finished"]
    assert task.calls[-2:] == ["park", "scan"] and ep.digs_done == 2

    result, hooks, task, _, _ = run_heap(units=9, take=2, dig_budget=2, final_scan=False)
    assert (result["end"], result["taken"]) == ("budget", [2, 2])
    assert [c[0] for c in hooks.calls if c[0] != "stepped"] == \
        ["started", "scanned", "planned", "dug", "scanned", "planned", "dug", "finished"]
    assert task.calls[-1] == "after 2"

    # a budget that the done test beats: the done test ends it
    result, *_ = run_heap(units=4, take=2, dig_budget=2)
    assert (result["end"], result["taken"]) == ("done", [2, 2])


def test_no_dig_and_a_failing_world_end_a_made_up_task():
    result, hooks, _, _, ep = run_heap(units=9, take=2, refuse_after=1)
    assert (result["end"], result["reason"], result["taken"]) == ("no_dig", "no dig wanted", [2])
    assert hooks.calls[-2:] == [("scanned", 2, 7), ("finished", "no_dig")]  # no planned hook without a plan or dig

    task, hooks = HeapTask(units=9), Hooks()
    ep = Episode(task, observer=hooks)
    ep.reset(1)
    ep.step()
    ep.sim.fail_next_park = True
    ep.step()
    assert ep.over and ep.result["end"] == "diverged" and ep.digs_done == 1
    assert ep.result["reason"] == "the fake world diverged (parking after 1 digs)"
    assert hooks.calls[-1] == ("finished", "diverged")


def test_the_made_up_task_runs_without_any_task_world_or_mujoco_module():
    """The platform imports no task of its own: the made-up task's episode, in a fresh interpreter,
    loads no module of ``excavsim.tasks`` or ``excavsim.world`` and no MuJoCo."""
    code = ("import sys; from tests.loop.test_made_up_task import run_heap; r = run_heap()[0]; "
            "assert r['end'] == 'done', r; "
            "print(sorted(m for m in sys.modules if m.startswith(('excavsim.tasks', 'excavsim.world', 'mujoco'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         cwd=pathlib.Path(__file__).resolve().parents[2])
    assert out.stdout.strip() == "[]", out.stdout


@pytest.mark.parametrize("budget", [1, 3])
def test_the_budget_is_the_most_digs(budget):
    result, *_ = run_heap(units=100, take=1, dig_budget=budget)
    assert result["end"] == "budget" and len(result["taken"]) == budget
