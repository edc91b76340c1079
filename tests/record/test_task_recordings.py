"""Every task on every machine records through its plug-in's ``recorder(path)``: a short episode
gives a file ``rerun rrd verify`` accepts, holding the task's entities with the episode's numbers; the
episode is the same recorded or not; an episode that raises, or is abandoned, still leaves a valid file."""

from __future__ import annotations

import re
import subprocess

import pyarrow as pa
import pytest
from rerun.chunk import RrdReader

from excavsim.errors import ExcavsimError
from excavsim.handoff.episode import ObserverGroup
from excavsim.loop.catalog import plugin, plugins
from excavsim.loop.scenario import EpisodeSpec, episode_summary, run_spec, spec_episode
from tests.record.test_record import entities, rerun_cli

TINY_SENSING = {"map": {"n_scans": 1}, "scanner": {"n_azimuth": 60, "n_elevation": 60}}
T3_GRID = {"grid": {"k_min_m": 1.8, "k_max_m": 2.6, "k_step_m": 0.2, "alpha_step_deg": 15.0, "d1_step_m": 0.04}}
SPECS = {  # (task, machine): a short episode of it
    ("trench", "t3"): EpisodeSpec(task="trench", goal="small", dig_budget=1, sensing=TINY_SENSING, planner=T3_GRID),
    ("trench", "tb035"): EpisodeSpec(task="trench", machine="tb035", goal="sand", dig_budget=1, sensing=TINY_SENSING),
    ("trench", "excavator_25t"): EpisodeSpec(task="trench", machine="excavator_25t", goal="sand", dig_budget=1,
                                             sensing=TINY_SENSING),
    ("pile_loading", "loader"): EpisodeSpec(task="pile_loading", machine="loader", dig_budget=1,
                                            pile_loading={"n_scans": 1}),
    ("pile_loading", "shovel"): EpisodeSpec(task="pile_loading", machine="shovel", dig_budget=1,
                                            pile_loading={"n_scans": 1}),
    ("dump_trial", "t3"): EpisodeSpec(task="dump_trial"),
    ("truck_loading", "excavator_25t"): EpisodeSpec(task="truck_loading", machine="excavator_25t", dig_budget=1),
}
CASES = [pytest.param(task, machine, id=f"{task}-{machine}") for task, machine in SPECS]
WALL = re.compile(r"wall|planning_s")  # summary keys that are wall-clock times


def test_every_task_and_machine_has_a_recording_case_and_a_recorder():
    assert set(SPECS) == {(t, m) for t, p in plugins().items() for m in p.machines}
    for name, p in plugins().items():
        assert p.can_record, name


def verify(path) -> None:
    done = subprocess.run([rerun_cli(), "rrd", "verify", str(path)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr


def scalars(path, entity: str) -> list[float]:
    """The scalar values logged to ``entity``, in the order of their times (sim_time, else the first timeline)."""
    rows = []
    for chunk in RrdReader(path).stream().to_chunks():
        if chunk.entity_path != entity or chunk.is_static:
            continue
        batch = chunk.to_record_batch()
        time = "sim_time" if "sim_time" in batch.schema.names else next(iter(chunk.timeline_names))
        ticks = batch.column(time).cast(pa.int64()).to_pylist()
        rows += [(t, v[0]) for t, v in zip(ticks, batch.column("Scalars:scalars").to_pylist()) if v]
    return [v for _, v in sorted(rows)]


def log_lines(path) -> list[str]:
    return [text[0] for chunk in RrdReader(path).stream().to_chunks() if chunk.entity_path == "/log"
            for text in chunk.to_record_batch().column("TextLog:text").to_pylist() if text]


def the_recording_holds_the_episode(path, task: str, machine: str, result) -> None:
    """What the recording of ``task`` on ``machine`` shows, against the episode's ``result``."""
    tree = entities(path)
    assert tree["/world"]["static"] == 1 and tree["/config"]["static"] == 1
    if task == "dump_trial":  # the trials' traces: joints and tip on sim_time, a metric per trial
        assert tree["/joint_deg/swing"]["sim_time"] == len(result.trace.times)
        assert scalars(path, "/metrics/time_s") == [pytest.approx(result.time_s)]
        return
    moving = {"t3": "bucket", "tb035": "bucket", "excavator_25t": "bucket", "loader": "bucket", "shovel": "bucket"}
    body = f"/world/{machine}/{moving[machine]}"
    assert tree[body]["sim_time"] == tree[body]["step"] >= 10, body  # sampled at 10 Hz of simulated time
    assert any(e.startswith(f"{body}/") and tree[e]["static"] == 1 for e in list(tree))  # its geoms, static
    assert tree["/world/soil/truth"]["static"] == 1 and tree["/world/soil/truth"]["sim_time"] >= 2
    if task == "trench":
        (dig,) = result.digs
        assert scalars(path, "/metrics/bucket_l") == [pytest.approx(1000 * dig.bucket_m3)]
        assert tree["/world/soil/scan"]["sim_time"] == 2 and tree["/joint_deg/" + ("wrist_pitch" if machine == "t3"
                                                                                  else "bucket")]["sim_time"] >= 10
        assert f"ended: {result.reason}" in log_lines(path)
    elif task == "pile_loading":
        volumes = scalars(path, "/volumes/total_m3")  # the soil's account: its total is kept
        assert len(volumes) >= 10 and max(volumes) - min(volumes) < 1e-3 * volumes[0]
        assert any(line.startswith(f"end: {result.reason}") for line in log_lines(path))
    else:  # truck_loading
        (p,) = result.passes
        assert scalars(path, "/pass/bucket_l") == [pytest.approx(1000 * p.bucket_m3)]
        assert tree["/world/truck/fill"]["sim_time"] >= 2


@pytest.mark.parametrize("task,machine", CASES)
def test_a_short_episode_records_and_is_the_same_episode_unrecorded(task, machine, tmp_path):
    spec = SPECS[task, machine]
    path = tmp_path / f"{task}_{machine}.rrd"
    result = run_spec(spec, observer=plugin(task).recorder(str(path)))
    verify(path)
    the_recording_holds_the_episode(path, task, machine, result)
    recorded, alone = episode_summary(result), episode_summary(run_spec(spec))
    assert {k: v for k, v in recorded.items() if not WALL.search(k)} == \
           {k: v for k, v in alone.items() if not WALL.search(k)}


class _RaiseAfterTheScan(ObserverGroup):
    """An observer of any task (a group of none) that raises at the first scan."""

    def scanned(self, *args) -> None:
        raise ExcavsimError("stop here")


@pytest.mark.parametrize("task,machine", CASES)
def test_an_episode_that_raises_or_is_abandoned_leaves_a_valid_recording(task, machine, tmp_path):
    spec = SPECS[task, machine]
    raised = tmp_path / "raised.rrd"
    with pytest.raises(ExcavsimError, match="stop here"):
        run_spec(spec, observer=ObserverGroup(plugin(task).recorder(str(raised)), _RaiseAfterTheScan()))
    verify(raised)
    assert "/config" in entities(raised)
    abandoned = tmp_path / "abandoned.rrd"
    recorder = plugin(task).recorder(str(abandoned))
    episode = spec_episode(spec, observer=recorder)
    episode.reset(spec.seed)
    episode.close()  # abandoned before its first scan: the observers hear finished(None)
    recorder.finished(None)  # and a second close does nothing
    verify(abandoned)
    assert "/world" in entities(abandoned)
