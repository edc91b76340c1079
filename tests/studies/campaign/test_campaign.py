"""Campaigns: grid expansion, stable ids, clear errors, parallel runs that survive a kill and resume."""

from __future__ import annotations

import csv
import json
import os
import pickle
import signal
import subprocess
import sys
import time

import pytest
import yaml

from excavsim import constants
from excavsim.cli import main
from excavsim.errors import ConfigError, ExcavsimError
from excavsim.studies.campaign import runner as cmp
from excavsim.loop.scenario import resolve
from excavsim.tasks.trench.spec import resolve_goal
from tests.children import Watch, kill

TINY_YAML = constants.CONFIGS_DIR / "campaigns" / "tiny.yaml"
TINY_BASE = {
    "goal": "small", "dig_budget": 1,
    "sensing": {"map": {"n_scans": 1}, "scanner": {"n_azimuth": 60, "n_elevation": 60}},
    "planner": {"grid": {"k_min_m": 1.8, "k_max_m": 2.6, "k_step_m": 0.2, "alpha_step_deg": 15.0, "d1_step_m": 0.04}},
}


def _strict_json(path):
    """Parse a result file as strict JSON (NaN or Infinity would not be JSON)."""
    def refuse(token):
        raise ValueError(f"{path}: non-JSON constant {token}")

    return json.loads(path.read_text(), parse_constant=refuse)


def _summary_ids(out):
    with open(out / "summary.csv", newline="") as f:
        return [row["id"] for row in csv.DictReader(f)]


def test_the_grid_expands_to_its_cartesian_product_with_stable_ids():
    data = {"name": "g", "base": TINY_BASE, "grid": {
        "soil": ["testbed_sand", "lean_clay"], "robot.joints.wrist_pitch.torque_limit_nm": [500, 1000],
        "planner.objective": ["volume", "lexicographic"], "seed": [0, 1, 2]}}
    spec = cmp.parse_campaign(data)
    episodes = cmp.expand_grid(spec)
    assert len(episodes) == 2 * 2 * 2 * 3 and len({e.id for e in episodes}) == len(episodes)
    assert [e.id for e in episodes] == [e.id for e in cmp.expand_grid(cmp.parse_campaign(data))]
    first = episodes[0]
    assert first.params == {"soil": "testbed_sand", "robot.joints.wrist_pitch.torque_limit_nm": 500,
                            "planner.objective": "volume", "seed": 0}
    resolved = resolve(first.spec)
    assert resolved.robot.joints.wrist_pitch.torque_limit_nm == 500 and resolved.planner.objective == "volume"
    assert resolved.scene.soil == "testbed_sand" and first.spec.seed == 0
    assert resolved.planner.grid.k_step_m == 0.2  # the base's overrides survive the grid's
    assert first.id.startswith("testbed_sand-torque_limit_nm500-volume-seed0-")
    # The id hashes the spec as written (sha256, not Python's salted hash): pinned across versions.
    tiny = cmp.expand_grid(cmp.load_campaign(TINY_YAML))
    assert [e.id for e in tiny] == ["seed0-c0a3876c9b", "seed1-1cc21bd3a5", "seed2-3ecfd50299", "seed3-81f00c9260"]


def test_a_dotted_goal_key_varies_the_named_goal():
    spec = cmp.parse_campaign({"name": "depth", "base": {"goal": "small"}, "grid": {"goal.depth_m": [0.1, 0.2]}})
    goals = [resolve(e.spec).goal for e in cmp.expand_grid(spec)]
    small = resolve_goal("small")
    assert [g.depth_m for g in goals] == [0.1, 0.2] and all(g.near_x_m == small.near_x_m for g in goals)


@pytest.mark.parametrize(("grid", "expected"), [
    ({"soil": ["testbed_sand", "moon_dust"]}, ["'soil'", "moon_dust", "testbed_sand"]),
    ({"robot.joints.wrist_ptch.torque_limit_nm": [500]}, ["robot.joints.wrist_ptch", "wrist_ptch", "unknown field"]),
    ({"sed": [0, 1]}, ["'sed'", "not an episode field", "seed"]),
    ({"seed.x": [0]}, ["'seed.x'", "single value"]),
    ({"seed": []}, ["grid.seed", "at least 1"]),
    ({"seed": [1, 1]}, ["same episode twice"]),
    ({"planner.objective": ["speed"]}, ["planner.objective", "speed"]),
    ({"seed": [0]}, ["report_by", "'soil'", "not among the grid keys"]),
])
def test_a_bad_campaign_names_the_key_the_value_and_the_fix(tmp_path, grid, expected):
    path = tmp_path / "bad.yaml"
    report_by = [["soil"]] if grid == {"seed": [0]} else []
    path.write_text(yaml.safe_dump({"name": "bad", "base": {"goal": "small"}, "grid": grid, "report_by": report_by}))
    with pytest.raises(ConfigError) as err:
        cmp.load_campaign(path)
    message = str(err.value)
    assert str(path) in message and all(e in message for e in expected), message


def test_the_cli_reports_a_bad_campaign_with_status_2(tmp_path, capsys):
    path = tmp_path / "bad.yaml"
    path.write_text("name: bad\nbase: {goal: small}\ngrid: {soil: [moon_dust]}\n")
    assert main(["campaign", str(path), "--out", str(tmp_path / "out")]) == 2
    assert "moon_dust" in capsys.readouterr().err


def test_an_out_dir_with_results_is_refused_without_resume(tmp_path, capsys):
    out = tmp_path / "out"
    (out / "episodes").mkdir(parents=True)
    (out / "episodes" / "seed0-c0a3876c9b.json").write_text("{}")
    with pytest.raises(ExcavsimError, match="--resume"):
        cmp.run_campaign(cmp.load_campaign(TINY_YAML), out, progress=None)
    assert main(["campaign", str(TINY_YAML), "--out", str(out)]) == 2
    assert "already holds 1 episode result" in capsys.readouterr().err


def test_a_failing_episode_becomes_an_error_record(monkeypatch):
    def explode(spec, **_):
        raise RuntimeError("the soil box caught fire")

    monkeypatch.setattr(cmp, "run_spec", explode)
    ep = cmp.expand_grid(cmp.load_campaign(TINY_YAML))[0]
    rec = cmp.run_episode_task(cmp._task(ep, constants.REPO_ROOT, False))
    assert rec["status"] == "error" and rec["error"] == "RuntimeError: the soil box caught fire"
    assert rec["summary"] is None and "explode" in rec["traceback"] and rec["id"] == ep.id
    json.dumps(rec, allow_nan=False)


class FakeRecorder:
    """A stand-in for a task's Rerun recorder: remembers the paths it was made for."""

    made: list = []

    def __init__(self, path, *, live=None):
        FakeRecorder.made.append((path, live))


def test_record_asks_the_episodes_task_for_its_recorder_of_the_episode_file(monkeypatch, tmp_path):
    """The worker asks the episode's task for its recorder (the campaign names no recorder), one per episode,
    for that episode's file; the task's own recorder, whatever the task."""
    from excavsim.loop import catalog

    FakeRecorder.made = []
    seen = []
    monkeypatch.setattr(catalog.plugin(catalog.DEFAULT_TASK), "recorder", FakeRecorder)
    monkeypatch.setattr(cmp, "run_spec", lambda spec, *, progress, observer: seen.append(observer))
    monkeypatch.setattr(cmp, "episode_summary", lambda _r, _task: {"digs": 0})
    monkeypatch.setattr(cmp, "dig_rows", lambda _r, _task: [])
    ep = cmp.expand_grid(cmp.load_campaign(TINY_YAML))[1]
    task = cmp._task(ep, tmp_path, True)
    pickle.loads(pickle.dumps(task))  # it travels to worker processes
    rec = cmp.run_episode_task(task)
    assert rec["status"] == "ok" and rec["recording"] == f"recordings/{ep.id}.rrd"
    assert FakeRecorder.made == [(str(tmp_path.resolve() / "recordings" / f"{ep.id}.rrd"), None)]
    assert isinstance(seen[0], FakeRecorder)


def test_record_over_a_task_without_a_recorder_is_refused_before_anything_runs(tmp_path):
    from excavsim.loop import catalog
    from excavsim.loop.plugin import TaskPlugin

    class Mute(TaskPlugin):
        name = "mute_test_task"
        title = "a task without a recorder"
        machines = ("t3",)

    catalog.register(Mute)
    try:
        spec = cmp.parse_campaign({"name": "rec", "base": {"task": "mute_test_task"}, "record": True})
        with pytest.raises(ExcavsimError, match="record: true, and task mute_test_task has no recorder"):
            cmp.run_campaign(spec, tmp_path / "out", progress=None)
    finally:
        catalog.unregister("mute_test_task")
    assert not list((tmp_path / "out" / "episodes").glob("*.json"))


def test_a_complete_out_dir_is_summarized_without_running_anything(tmp_path):
    spec = cmp.parse_campaign({"name": "fake", "base": {"goal": "small"},
                               "grid": {"soil": ["testbed_sand", "lean_clay"], "seed": [0, 1]}})
    episodes = cmp.expand_grid(spec)
    (tmp_path / "episodes").mkdir()
    for i, ep in enumerate(episodes):
        ok = i != 3
        summary = {"end": "done" if i == 0 else "budget", "digs": 2 + i, "dug_l_per_dig": 10.0 + i,
                   "removed_fraction": 0.5 + 0.1 * i, "dug_l": [1.0, 2.0]}
        rec = {"id": ep.id, "status": "ok" if ok else "error", "summary": summary if ok else None,
               "error": None if ok else "ExcavsimError: diverged\ndetails"}
        (tmp_path / "episodes" / f"{ep.id}.json").write_text(json.dumps(rec))
    lines = []
    report = cmp.run_campaign(spec, tmp_path, resume=True, progress=lines.append)
    assert report.ran == 0 and report.errors == 1
    assert _summary_ids(tmp_path) == [e.id for e in episodes]
    with open(tmp_path / "summary.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [r["soil"] for r in rows] == ["testbed_sand", "testbed_sand", "lean_clay", "lean_clay"]
    assert rows[3]["status"] == "error" and rows[3]["error"] == "ExcavsimError: diverged" and rows[3]["digs"] == ""
    assert "dug_l" not in rows[0]  # per-dig lists stay in the episode files
    assert {p.name for p in report.plots} == {"by_soil.png"}
    assert all(p.stat().st_size > 10_000 for p in report.plots)
    table = next(line for line in lines if line.startswith("soil"))
    assert "lean_clay" in table and "l/dig" in table
    assert (tmp_path / "campaign.yaml").exists()


def test_grouped_tables_pool_the_other_keys_and_count_repeated_failures(tmp_path):
    from excavsim.studies.campaign.report import repeated_failures

    # a dig one grid cell (k 0.1 m, alpha 5 deg, d1 0.01 m) from a failed one repeats it; two cells away
    # or before any failure does not; a fallback dig (no action) is never a repeat
    digs = [{"k_m": 2.0, "alpha_deg": 10.0, "d1_m": 0.1, "failure": ""},
            {"k_m": 2.0, "alpha_deg": 10.0, "d1_m": 0.1, "failure": "stall"},
            {"k_m": 2.1, "alpha_deg": 15.0, "d1_m": 0.11, "failure": ""},
            {"k_m": 2.2, "alpha_deg": 10.0, "d1_m": 0.1, "failure": "stall"},
            {"k_m": float("nan"), "alpha_deg": float("nan"), "d1_m": float("nan"), "failure": ""},
            {"k_m": 2.2, "alpha_deg": 10.0, "d1_m": 0.12, "failure": ""}]
    assert repeated_failures(digs, (0.1, 5.0, 0.01)) == 1
    assert repeated_failures(digs, (0.1, 5.0, 0.02)) == 2
    spec = cmp.parse_campaign({"name": "fake", "base": {"goal": "small"}, "report_by": [["memory"]],
                               "grid": {"memory": [True, False], "seed": [0, 1]}})
    (tmp_path / "episodes").mkdir()
    for i, ep in enumerate(cmp.expand_grid(spec)):
        summary = {"end": "done" if i % 2 == 0 else "budget", "digs": 4, "dug_l_per_dig": 5.0 + i, "stalls": i,
                   "failed_digs": i, "removed_fraction": 0.9}
        rec = {"id": ep.id, "status": "ok", "summary": summary, "spec": ep.spec.model_dump(mode="json"),
               "digs": digs if i == 1 else []}
        (tmp_path / "episodes" / f"{ep.id}.json").write_text(json.dumps(rec))
    lines = []
    cmp.run_campaign(spec, tmp_path, resume=True, progress=lines.append)
    text = "\n".join(lines)
    assert "by memory:" in text
    table = text.split("by memory:\n", 1)[1].splitlines()
    assert table[0].split() == ["memory", "episodes", "done", "stalls/ep", "l/dig", "digs", "to", "done", "failed",
                                "%", "repeats"]
    by = {line.split()[0]: line.split() for line in table[1:3]}
    # memory true: seeds 0, 1 are episodes 0 and 1 (done, budget); stalls 0 and 1; 1 failed of 8 digs
    assert by["True"][1:] == ["2", "1/2", "0.50", "5.5", "4.0", "12.5", "1"]
    assert by["False"][1:] == ["2", "1/2", "2.50", "7.5", "4.0", "62.5", "0"]


@pytest.mark.slow
def test_a_killed_campaign_resumes_without_duplicates_or_gaps(tmp_path):
    """Four tiny episodes on two processes, killed (SIGKILL, whole process group) after the first
    result is written, then resumed: every episode ends with exactly one result, and the results
    written before the kill are left as they were."""
    out = tmp_path / "out"
    ep_dir = out / "episodes"
    cmd = [sys.executable, "-m", "excavsim.cli", "campaign", str(TINY_YAML), "--out", str(out), "--workers", "2"]
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
            os.killpg(proc.pid, signal.SIGKILL)  # the CLI, its forkserver and its workers
            proc.wait()
    before = {p.name: (p.stat().st_mtime_ns, p.read_bytes()) for p in ep_dir.glob("*.json")}
    assert 1 <= len(before) < 4

    resumed = subprocess.run([*cmd, "--resume"], capture_output=True, text=True, cwd=constants.REPO_ROOT,
                             timeout=300)
    assert resumed.returncode == 0, resumed.stdout + resumed.stderr
    assert f"{len(before)} already done, {4 - len(before)} to run" in resumed.stdout
    ids = [e.id for e in cmp.expand_grid(cmp.load_campaign(TINY_YAML))]
    files = sorted(p.name for p in ep_dir.iterdir())
    assert files == sorted(f"{i}.json" for i in ids)  # no duplicate, no gap, no temporary file left
    for i in ids:
        rec = _strict_json(ep_dir / f"{i}.json")
        assert rec["id"] == i and rec["status"] == "ok" and rec["summary"]["digs"] == 1
        assert len(rec["digs"]) == 1 and rec["digs"][0]["outcome"]  # the per-dig rows travel too
    assert {p.name: (p.stat().st_mtime_ns, p.read_bytes()) for p in ep_dir.glob("*.json")
            if p.name in before} == before
    assert _summary_ids(out) == ids
    assert sum(line.startswith("[") for line in resumed.stdout.splitlines()) == 4 - len(before)


def test_without_ray_the_error_names_the_extra(monkeypatch, tmp_path):
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray raises ImportError
    with pytest.raises(ExcavsimError, match=r"pip install 'excavsim\[ray\]'"):
        cmp.run_campaign(cmp.load_campaign(TINY_YAML), tmp_path, ray_address="local", progress=None)
    assert not (tmp_path / "episodes").exists()


@pytest.mark.slow
def test_a_campaign_runs_on_ray(tmp_path):
    if os.environ.get("EXCAVSIM_REQUIRE_RAY"):  # CI installs the extra: a missing Ray fails, not skips
        import ray
    else:
        ray = pytest.importorskip("ray", reason="Ray is an optional extra (pip install 'excavsim[ray]')")
    if not hasattr(ray, "remote"):
        pytest.skip("a folder named ray shadows the package; Ray is not installed")
    spec = cmp.parse_campaign({"name": "ray", "base": TINY_BASE, "grid": {"seed": [0, 1]}})
    with Watch() as watch:
        report = cmp.run_campaign(spec, tmp_path, workers=2, ray_address="local", progress=None)
    assert watch.seen, "the campaign started no Ray process"
    left = watch.left()  # the Ray runtime the campaign launched is shut down: its processes are gone
    kill(left)
    assert not left, [watch.seen[p] for p in left]
    assert report.ran == 2 and report.errors == 0
    assert _summary_ids(tmp_path) == [e.id for e in report.episodes]
    assert all(_strict_json(tmp_path / "episodes" / f"{e.id}.json")["summary"]["digs"] == 1
               for e in report.episodes)


def test_progress_lines_count_and_tolerate_numbers_that_were_not_finite():
    rec = {"id": "a", "status": "ok", "wall_s": 3.0,
           "summary": {"task": "trench", "end": "budget", "digs": 12, "dug_l_per_dig": None, "removed_fraction": 0.85}}
    assert cmp._progress_line(2, 8, rec, 75.0) == "[2/8] a: budget: 12 digs, ? l/dig, 85 % removed, ? stalls (3 s); " \
                                                 "ETA 1 min 15 s"
    err = {"id": "b", "status": "error", "error": "ExcavsimError: diverged\ntraceback", "wall_s": 1.0}
    assert cmp._progress_line(8, 8, err, 0.0) == "[8/8] b: ERROR ExcavsimError: diverged"


def test_workers_share_the_cores_out_as_numba_threads():
    from excavsim.studies.campaign.runner import threads_per_worker

    assert threads_per_worker(2, 8, cores=2) == 1  # two busy workers on two cores: one thread each
    assert threads_per_worker(1, 8, cores=2) == 2  # one worker may use both
    assert threads_per_worker(4, 1, cores=8) == 8  # only one episode: only one worker runs
    assert threads_per_worker(16, 64, cores=2) == 1  # never fewer than one
