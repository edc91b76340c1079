"""Campaigns over tasks: a grid that varies the task (trench, pile_loading, dump_trial), one table, resumable."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time

import pytest
import yaml

from tests.studies.campaign.test_campaign import TINY_BASE

from excavsim import constants
from excavsim.errors import ConfigError
from excavsim.studies.campaign import runner as cmp
from excavsim.studies.campaign.report import format_table, group_table, summary_rows

TASKS = [{"task": "pile_loading", "machine": "shovel", "pile_loading": {"n_scans": 1}}, "dump_trial", "trench"]


def _spec(grid, base=TINY_BASE):
    return cmp.parse_campaign({"name": "mixed", "base": base, "grid": grid})


def test_the_base_trench_fields_go_to_the_trench_episodes_only():
    eps = cmp.expand_grid(_spec({"task": TASKS, "seed": [0]}))
    by = {e.spec.task: e.spec for e in eps}
    assert [e.name for e in eps] == ["task=pile_loading_shovel seed=0", "task=dump_trial seed=0", "task=trench seed=0"]
    assert [e.id.rsplit("-", 1)[0] for e in eps] == ["pile_loading_shovel-seed0", "dump_trial-seed0", "trench-seed0"]
    trench, load, trial = by["trench"], by["pile_loading"], by["dump_trial"]
    assert trench.options.goal == "small" and trench.dig_budget == 1 and trench.options.planner
    assert not hasattr(load.options, "goal") and not hasattr(load.options, "planner") and load.dig_budget == 1
    assert load.machine_name == "shovel" and load.options.pile_loading == {"n_scans": 1}
    assert trial.dig_budget == 20 and set(trial.options.model_fields) == {"dump_trial"}  # a trial has no dig budget
    # a grid key of one task's field beside a varied task is refused (it would run the others twice)
    with pytest.raises(ConfigError, match="grid key 'planner.grid.k_step_m' configures task trench only; this "
                                          "episode's task is pile_loading: put it in that task's value"):
        _spec({"task": ["trench", "pile_loading"], "planner.grid.k_step_m": [0.2, 0.3]})
    with pytest.raises(ConfigError, match="a mapping value must name its task"):
        _spec({"task": [{"machine": "shovel"}]})
    with pytest.raises(ConfigError, match="machine 'shovel' does not do task dump_trial"):
        _spec({"task": [{"task": "dump_trial", "machine": "shovel"}]})


def test_the_tasks_campaign_file_is_valid_and_a_trench_grid_keeps_its_ids():
    spec = cmp.load_campaign(constants.CONFIGS_DIR / "campaigns" / "tasks.yaml")
    assert {(e.spec.task, e.spec.machine_name) for e in cmp.expand_grid(spec)} == {
        ("trench", "t3"), ("pile_loading", "loader"), ("pile_loading", "shovel"), ("dump_trial", "t3")}
    tiny = cmp.expand_grid(cmp.load_campaign(constants.CONFIGS_DIR / "campaigns" / "tiny.yaml"))
    assert [e.id for e in tiny] == ["seed0-c0a3876c9b", "seed1-1cc21bd3a5", "seed2-3ecfd50299", "seed3-81f00c9260"]


def test_one_table_with_each_tasks_metrics_where_they_apply(tmp_path):
    spec = _spec({"task": TASKS[:2], "seed": [0]})
    eps = cmp.expand_grid(spec)
    ep_dir = tmp_path / "episodes"
    ep_dir.mkdir()
    for ep in eps:
        rec = cmp.run_episode_task(cmp._task(ep, tmp_path, False))
        assert rec["status"] == "ok", rec["error"]
        (ep_dir / f"{ep.id}.json").write_text(json.dumps(rec))
    rows = summary_rows(eps, ep_dir)
    assert [(r["task"], r["machine"]) for r in rows] == [("pile_loading", "shovel"), ("dump_trial", "t3")]
    lines = [re.split(r"\s{2,}", line.strip()) for line in format_table(spec, rows).splitlines()]
    head = lines[0]
    assert head[:2] == ["task", "machine"] and "deliv. l" in head and "cycle s" in head
    load, truck = (dict(zip(head, line, strict=True)) for line in lines[1:])
    assert load["task"] == "pile_loading" and float(load["deliv. l"]) > 100 and load["cycle s"] == "-"
    assert truck["task"] == "dump_trial" and truck["deliv. l"] == "-" and 1 < float(truck["cycle s"]) < 20
    assert truck["done"] == "1" and truck["removed %"] == "-" and float(truck["dumped l"]) > 5
    grouped = [line.split() for line in group_table(rows, ["task"], ep_dir).splitlines()[1:]]  # report_by too
    assert [g[0] for g in grouped] == ["dump_trial", "pile_loading"] and grouped[0][2] == "1/1"


@pytest.mark.slow
def test_a_killed_campaign_over_tasks_resumes_without_duplicates_or_gaps(tmp_path):
    """Six episodes of three tasks on two processes, killed (SIGKILL, the process group) after the first
    result, then resumed: one result per episode, those from before the kill untouched, one table."""
    path = tmp_path / "mixed.yaml"
    path.write_text(yaml.safe_dump({"name": "mixed", "base": TINY_BASE, "grid": {"task": TASKS, "seed": [0, 1]}},
                                   sort_keys=False))
    out = tmp_path / "out"
    ep_dir = out / "episodes"
    cmd = [sys.executable, "-m", "excavsim.cli", "campaign", str(path), "--out", str(out), "--workers", "2"]
    with open(tmp_path / "first.log", "w") as log:
        proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, cwd=constants.REPO_ROOT,
                                start_new_session=True)
        try:
            deadline = time.monotonic() + 180
            while not (ep_dir.exists() and any(ep_dir.glob("*.json"))):
                assert proc.poll() is None, f"ended before the kill: {(tmp_path / 'first.log').read_text()}"
                assert time.monotonic() < deadline, "no episode finished in 180 s"
                time.sleep(0.02)
        finally:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    before = {p.name: p.read_bytes() for p in ep_dir.glob("*.json")}
    assert 1 <= len(before) < 6
    resumed = subprocess.run([*cmd, "--resume"], capture_output=True, text=True, cwd=constants.REPO_ROOT,
                             timeout=300)
    assert resumed.returncode == 0, resumed.stdout + resumed.stderr
    assert f"{len(before)} already done, {6 - len(before)} to run" in resumed.stdout
    ids = [e.id for e in cmp.expand_grid(cmp.load_campaign(path))]
    assert sorted(p.name for p in ep_dir.iterdir()) == sorted(f"{i}.json" for i in ids)
    assert {p.name: p.read_bytes() for p in ep_dir.glob("*.json") if p.name in before} == before
    recs = [json.loads((ep_dir / f"{i}.json").read_text()) for i in ids]
    assert [r["status"] for r in recs] == ["ok"] * 6
    assert [r["summary"]["task"] for r in recs] == ["pile_loading", "pile_loading", "dump_trial", "dump_trial", "trench", "trench"]
    table = resumed.stdout[resumed.stdout.index("task "):].splitlines()
    assert [line.split()[:2] for line in table[1:4]] == [["pile_loading", "shovel"], ["dump_trial", "t3"], ["trench", "t3"]]
