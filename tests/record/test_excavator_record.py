"""Rerun recordings of an excavator run: the TB035's teleoperation recorded (``excavsim playback --machine tb035
--teleop --record``) holds the machine's bodies moving, its cylinders, the soil and the signals."""

from __future__ import annotations

import subprocess

import numpy as np
import pytest
from rerun.chunk import RrdReader

from excavsim.apps.playback.machines import adapter_for
from excavsim.apps.playback.teleop import teleoperate
from excavsim.cli import main
from excavsim.config import get_soil
from excavsim.errors import ExcavsimError
from excavsim.execution.teleop import FINISH
from excavsim.record.excavator import ExcavatorRecorder
from tests.record.test_record import entities, rerun_cli

MOVING = ("upper", "boom", "stick", "bucket", "rocker", "link")


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    path = tmp_path_factory.mktemp("exc") / "tb035.rrd"
    recorder = ExcavatorRecorder(path, rate_hz=10.0, soil_period_s=0.5)
    demo = teleoperate("z" * 6 + "s" * 12 + "a" * 10 + FINISH, machine="tb035", observer=recorder)
    return path, demo


def test_the_recording_passes_rerun_verify(recording):
    path, _ = recording
    done = subprocess.run([rerun_cli(), "rrd", "verify", str(path)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr


def test_the_recording_shows_the_machine_moving_and_the_soil(recording):
    path, demo = recording
    ent = entities(path)
    for body in MOVING:
        assert ent[f"/world/tb035/{body}"]["sim_time"] >= 5, body  # sampled at 10 Hz over the session
    assert ent["/world/tb035/base"]["static"] >= 1  # the tracks do not move
    assert ent["/world/tb035/bucket/bucket_shell"]["static"] >= 1  # a geom, static in its body's frame
    assert ent["/world/tb035/cylinders"]["sim_time"] >= 5
    assert ent["/world/pit/ground_front"]["static"] >= 1
    assert ent["/world/soil/truth"]["sim_time"] >= 3  # start, every 0.5 s, end
    for f in ("swing", "boom", "stick", "bucket"):
        assert ent[f"/joint_deg/{f}"]["sim_time"] >= 5 and ent[f"/cylinder_kn/{f}"]["sim_time"] >= 5
    assert ent["/soil/bucket_l"]["sim_time"] >= 5


def bucket_positions(path) -> np.ndarray:
    """The bucket's logged translations, in time order."""
    rows = []
    for chunk in RrdReader(path).stream().to_chunks():
        if chunk.entity_path != "/world/tb035/bucket" or chunk.is_static:
            continue
        table = chunk.to_record_batch()
        col = next(c for c in table.schema.names if c.endswith("Transform3D:translation"))
        times = next(c for c in table.schema.names if c == "sim_time")
        for t, v in zip(table.column(times).to_pylist(), table.column(col).to_pylist()):
            if v:
                rows.append((t, v[0]))
    return np.array([p for _, p in sorted(rows, key=lambda r: r[0])])


def test_the_bucket_is_logged_where_the_world_has_it(tmp_path):
    """A swing of the world recorded at 10 Hz: the bucket's logged positions follow the world's, sample by
    sample, and its last bearing is the swing angle."""
    rig = adapter_for("tb035").rig(get_soil("testbed_sand"), 0)
    path = tmp_path / "swing.rrd"
    recorder = ExcavatorRecorder(path, rate_hz=10.0)
    recorder.started(rig.world)
    bucket = rig.world.model.body("bucket").id
    truth = [rig.world.data.xpos[bucket].copy()]
    q = rig.world.joint_angles()
    for k in range(1, 101):  # 2 s: swing to 0.8 rad
        rig.world.step(np.r_[0.8 * min(1.0, k / 60), q[1:]])
        recorder.stepped(rig.world)
        if k % 5 == 0:
            truth.append(rig.world.data.xpos[bucket].copy())
    recorder.finished(rig.world)
    pos = bucket_positions(path)
    assert len(pos) == len(truth) + 1  # every 0.1 s, and the end once more
    assert pos[:-1] == pytest.approx(np.array(truth), abs=1e-5)
    swing = rig.world.joint_angles()[0]  # the bucket pin is in the arm plane: its bearing is the swing angle
    assert swing > 0.3 and np.arctan2(pos[-1, 1], pos[-1, 0]) == pytest.approx(swing, abs=1e-4)


def test_the_command_records_a_tb035_session_and_refuses_a_bad_file(tmp_path):
    rrd = tmp_path / "s.rrd"
    assert main(["playback", "--machine", "tb035", "--teleop", "--keys", "zzs" + FINISH, "--record", str(rrd),
                 "--out", str(tmp_path / "o")]) == 0
    assert rrd.exists() and entities(rrd)["/world/tb035/boom"]["sim_time"] >= 1
    with pytest.raises(ExcavsimError, match="rrd"):
        ExcavatorRecorder(tmp_path / "x.txt")
    rec = ExcavatorRecorder(tmp_path / "y.rrd")
    with pytest.raises(ExcavsimError, match="before started"):
        rec.stepped(None)
