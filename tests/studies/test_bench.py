"""The bench table: targets judged met or missed, CPU and wall timings reported (no timing asserted)."""

from __future__ import annotations

import numpy as np
import pytest

from excavsim.studies import bench
from excavsim.studies.bench import Row, Timing, run_benchmarks


def test_rows_judge_their_targets_in_both_senses():
    assert Row("a", 40.0, "ms", "", 50.0, "<=").met is True
    assert Row("a", 60.0, "ms", "", 50.0, "<=").met is False
    assert Row("b", 120.0, "x", "", 100.0, ">=").met is True
    assert Row("b", 80.0, "x", "", 100.0, ">=").met is False
    assert Row("c", 1.0, "x", "").met is None


def test_timing_reports_median_and_range_of_cpu_and_wall():
    t = Timing(np.array([0.3, 0.1, 0.2]), np.array([0.5, 0.4, 0.9]))
    assert t.cpu_median == 0.2 and t.wall_median == 0.5
    text = t.describe(1e3, "ms")
    assert "CPU 200 [100-300] ms" in text and "wall 500 [400-900] ms" in text and "3 runs" in text
    timed = bench._timed(lambda: sum(range(1000)), 4)
    assert timed.cpu.shape == (4,) and np.all(timed.cpu >= 0) and np.all(timed.wall > 0)


def test_the_table_says_which_targets_are_missed(monkeypatch):
    monkeypatch.setattr(bench, "BENCHMARKS", {"fake": lambda: [
        Row("fast thing", 10.0, "ms", "note", 50.0, "<="),
        Row("slow thing", 90.0, "ms", "", 50.0, "<="),
        ("an old-style row", 3.0, "x", "no target"),
    ]})
    lines: list[str] = []
    rows = run_benchmarks(["fake"], echo=lines.append)
    text = "\n".join(lines)
    assert len(rows) == 3 and all(isinstance(r, Row) for r in rows)
    fast = next(line for line in lines if line.startswith("fast thing"))
    slow = next(line for line in lines if line.startswith("slow thing"))
    assert " met " in fast and "MISSED" in slow
    assert "targets: 1 of 2 met; missed: slow thing (90 ms, target <= 50)" in text


@pytest.mark.slow
def test_warm_up_runs_an_episode_and_the_reference_planner():
    from excavsim.loop.warmup import warm_up

    lines: list[str] = []
    seconds = warm_up(say=lines.append)
    assert seconds > 0 and lines[-1].startswith("warm: ")
    assert any("short episode" in line for line in lines) and any("reference path" in line for line in lines)
