"""Rerun recordings of episodes: a valid, complete file per episode with the documented entity tree,
and ``excavsim replay``."""

from __future__ import annotations

import pathlib
import shutil
import subprocess
import sys
from collections import defaultdict

import numpy as np
import pyarrow as pa
import pytest
from rerun.chunk import RrdReader

from excavsim.cli import main
from excavsim.errors import ExcavsimError
from excavsim.record import TrenchRecorder
from excavsim.record.base import recording_id_for
from excavsim.record.geometry import grid_triangles, quat_xyzw
from excavsim.loop.scenario import EpisodeSpec, run_spec

SPEC = EpisodeSpec(
    name="recorded", goal="small", dig_budget=1,
    sensing={"map": {"n_scans": 2}, "scanner": {"n_azimuth": 80, "n_elevation": 80}},
    planner={"grid": {"k_min_m": 1.8, "k_max_m": 2.6, "alpha_step_deg": 10.0, "d1_step_m": 0.02}})
BODIES = ("waist", "upper_arm", "forearm", "wrist_pitch_link", "wrist_yaw_link", "wrist_roll_link", "bucket")


def rerun_cli() -> str:
    here = pathlib.Path(sys.executable).parent / "rerun"
    exe = str(here) if here.exists() else shutil.which("rerun")
    # rerun-sdk installs the CLI next to the interpreter; without it `rrd verify` would go unchecked
    assert exe is not None, "the rerun CLI (installed with rerun-sdk) is missing: reinstall excavsim"
    return exe


def entities(path: pathlib.Path) -> dict[str, dict]:
    """Per entity path: rows logged static and per timeline, read back from the file."""
    out: dict[str, dict] = defaultdict(lambda: defaultdict(int))
    for chunk in RrdReader(path).stream().to_chunks():
        keys = ["static"] if chunk.is_static else list(chunk.timeline_names)
        for key in keys:
            out[chunk.entity_path][key] += chunk.num_rows
    return out


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    path = tmp_path_factory.mktemp("rec") / "ep.rrd"
    result = run_spec(SPEC, observer=TrenchRecorder(path))
    return path, result


def test_a_recorded_episode_passes_rerun_verify(recording):
    path, _ = recording
    done = subprocess.run([rerun_cli(), "rrd", "verify", str(path)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr


def test_the_recording_holds_the_documented_entity_tree(recording):
    path, result = recording
    tree = entities(path)
    for body in BODIES:  # every moving body has a pose per sample, on both timelines
        assert tree[f"/world/t3/{body}"]["sim_time"] == tree[f"/world/t3/{body}"]["dig"] > 100
    assert tree["/world/t3/bucket/bucket_shell"]["static"] == 1
    assert tree["/world/soil/truth"]["static"] == 1  # the triangles, once
    assert tree["/world/soil/truth"]["sim_time"] == 1 + len(result.digs)  # at the start and after each dig
    assert tree["/world/soil/scan"]["sim_time"] == len(result.digs) + 1  # one map per scan
    for static in ("/world", "/world/goal", "/world/goal/footprint", "/config", "/plan/axes"):
        assert tree[static]["static"] >= 1, static
    for temporal in ("/world/plan/path", "/world/exec/path", "/plan/feasible", "/plan/chosen", "/summary",
                     "/ft/force/norm", "/ft/tip/x", "/torque/wrist_pitch",
                     "/truth/soil_force_n", "/metrics/bucket_l", "/metrics/efficiency", "/wall/planning_s"):
        assert tree[temporal]["sim_time"] >= 1, temporal
    assert tree["/metrics/bucket_l"]["dig"] == len(result.digs)
    assert tree["/summary"]["sim_time"] == len(result.digs) + 2  # at the start, after every dig, at the end
    # 37 s simulated at the default 10 Hz: one sample per 0.1 s
    assert tree["/torque/shoulder"]["sim_time"] == pytest.approx(10 * result.sim_time_s, rel=0.05)


def summaries(path: pathlib.Path) -> list[tuple[float, str]]:
    """The /summary documents of a recording: (sim_time [s], markdown), in time order."""
    found = []
    for chunk in RrdReader(path).stream().to_chunks():
        if chunk.entity_path == "/summary" and not chunk.is_static:
            batch = chunk.to_record_batch()
            times = batch.column("sim_time").cast(pa.int64()).to_pylist()
            texts = batch.column("TextDocument:text").to_pylist()
            found += [(t / 1e9, text[0]) for t, text in zip(times, texts)]
    return sorted(found)


def test_the_summary_grows_after_every_dig_on_sim_time(recording):
    """The summary is there from the start and gains a table row per dig, so the viewer shows it at every
    time of the sim_time timeline, not only at the end."""
    path, result = recording
    docs = summaries(path)
    assert docs[0][0] == 0.0 and "No dig yet" in docs[0][1]
    for k in range(1, len(result.digs) + 1):
        rows = [line for line in docs[k][1].splitlines() if line.startswith("| ") and line[2].isdigit()]
        assert len(rows) == k, docs[k][1]
    end = docs[-1][1]
    assert docs[-1][0] == pytest.approx(result.sim_time_s, abs=0.2)
    assert "**Ended**" in end and result.reason in end and "wall" not in end


def test_an_episode_that_raises_still_leaves_a_complete_separate_recording(recording, tmp_path):
    class FailingAfterTheScan(TrenchRecorder):
        def scanned(self, index, emap, accuracy):
            super().scanned(index, emap, accuracy)
            raise ExcavsimError("stop here")

    path = tmp_path / "broken.rrd"
    with pytest.raises(ExcavsimError, match="stop here"):
        run_spec(SPEC, observer=FailingAfterTheScan(path))
    done = subprocess.run([rerun_cli(), "rrd", "verify", str(path)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    tree = entities(path)
    assert tree["/summary"]["sim_time"] == 2 and tree["/world/soil/scan"]["sim_time"] == 1  # the start, the error
    assert "ended with an error" in summaries(path)[-1][1]
    assert "/world/exec/path" not in tree  # nothing of the other episode leaked in
    ids = {RrdReader(p).recordings()[0].recording_id for p in (path, recording[0])}
    assert len(ids) == 2


def contents(path: pathlib.Path) -> dict[tuple[str, bool], list[str]]:
    """A recording's rows as text, per entity path and staticness, in the order they were logged (by
    row id), without the row ids (wall-clock stamps) and without how the rows were cut into chunks."""
    rows: dict[tuple[str, bool], list[tuple[bytes, str]]] = defaultdict(list)
    for chunk in RrdReader(path).stream().to_chunks():
        batch = chunk.to_record_batch()
        columns = {name: (col.cast(pa.int64()) if pa.types.is_duration(col.type) else col).to_pylist()
                   for name, col in zip(batch.schema.names, batch.columns)}  # durations as integer ns
        row_ids = columns.pop("rerun.controls.RowId")
        for i, row_id in enumerate(row_ids):
            cells = {name: values[i] for name, values in columns.items() if values[i] is not None}
            rows[chunk.entity_path, chunk.is_static].append((row_id, repr(sorted(cells.items()))))
    return {key: [text for _, text in sorted(found)] for key, found in rows.items()}


def test_the_same_episode_records_the_same_contents(recording, tmp_path):
    """Same seed, same configuration, same file name: the same recording id and, decoded, the same rows
    on every entity but the wall-clock times of ``/wall``. Rerun 0.41 stamps rows and chunks with
    wall-clock ids, so the bytes differ; that they differ is checked too, so that a Rerun that allows
    byte identity is noticed."""
    first, _ = recording
    again = tmp_path / first.name
    run_spec(SPEC, observer=TrenchRecorder(again))
    ids = [RrdReader(p).recordings()[0].recording_id for p in (first, again)]
    assert ids[0] == ids[1] == recording_id_for(first.name, SPEC.seed, _config_of(first))
    a, b = contents(first), contents(again)
    wall = {key for key in a if key[0].startswith("/wall")}
    assert wall == {("/wall/planning_s", False), ("/wall/planning_s", True)}
    assert len(a) > 50 and a.keys() == b.keys()
    for key in a.keys() - wall:
        assert a[key] == b[key], key
    assert first.read_bytes() != again.read_bytes()


def _config_of(path: pathlib.Path) -> str:
    """The resolved configuration a recording holds (its static /config TextDocument)."""
    for chunk in RrdReader(path).stream().to_chunks():
        if chunk.entity_path == "/config":
            return chunk.to_record_batch().to_pydict()["TextDocument:text"][0][0]
    raise AssertionError(f"{path} has no /config")


def test_recording_ids_differ_with_the_seed_the_configuration_and_the_file_name():
    base = recording_id_for("ep.rrd", 0, "config")
    assert base == recording_id_for("ep.rrd", 0, "config")
    assert len({base, recording_id_for("ep.rrd", 1, "config"), recording_id_for("ep.rrd", 0, "other"),
                recording_id_for("other.rrd", 0, "config")}) == 4


def test_a_recorder_records_one_episode_only(recording):
    rec = TrenchRecorder(recording[0].with_name("again.rrd"))
    rec.rec = object()  # as after started()
    with pytest.raises(ExcavsimError, match="one episode"):
        rec.started(None, None, None, None)
    with pytest.raises(ExcavsimError, match="rate_hz"):
        TrenchRecorder("x.rrd", rate_hz=0.0)


def test_quaternions_go_from_mujoco_wxyz_to_rerun_xyzw():
    np.testing.assert_array_equal(quat_xyzw([1.0, 0.0, 0.0, 0.0]), [0.0, 0.0, 0.0, 1.0])
    np.testing.assert_array_equal(quat_xyzw([[0.5, 0.1, 0.2, 0.3]]), np.float32([[0.1, 0.2, 0.3, 0.5]]))


def test_grid_triangles_face_up_and_cover_the_grid():
    rows, cols = 3, 4
    tris = grid_triangles(rows, cols)
    assert tris.shape == (2 * (rows - 1) * (cols - 1), 3)
    x, y = np.meshgrid(np.arange(cols), np.arange(rows))
    v = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], axis=-1)[tris]
    normal_z = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])[:, 2]
    np.testing.assert_allclose(normal_z, 1.0)  # every triangle half a unit cell, counter-clockwise from +z


def test_replay_of_a_missing_file_exits_2_with_a_message(tmp_path, capsys):
    assert main(["replay", str(tmp_path / "missing.rrd")]) == 2
    err = capsys.readouterr().err
    assert "no recording at" in err and "missing.rrd" in err


def test_replay_dry_run_prints_the_viewer_command(recording, capsys):
    assert main(["replay", str(recording[0]), "--dry-run"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("would run: ") and "rerun" in out and str(recording[0]) in out


def test_replay_without_a_display_prints_the_command_instead(recording, capsys, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr(sys, "platform", "linux")
    monkeypatch.setattr(subprocess, "run", lambda *a, **k: pytest.fail("no viewer may start without a display"))
    assert main(["replay", str(recording[0])]) == 0
    out = capsys.readouterr().out
    assert "no display" in out and str(recording[0]) in out


def test_trench_record_wants_an_rrd_file(capsys):
    assert main(["trench", "--dig-budget", "1", "--record", "episode.txt"]) == 2
    assert "--record must name an .rrd file" in capsys.readouterr().err
