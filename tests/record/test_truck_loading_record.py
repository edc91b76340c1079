"""Rerun recording of a truck-loading episode (``excavsim run configs/specs/excavator_truck.yaml --record``):
a valid file with the machine moving, the truck, its bed's fill after each pass, the pit's terrain and the
per-pass metrics, and what it shows agrees with the world."""

from __future__ import annotations

import math
import subprocess

import numpy as np
import pyarrow as pa
import pytest
from rerun.chunk import RrdReader

from excavsim.cli import main
from excavsim.errors import ExcavsimError
from excavsim.tasks.truck_loading import task as truck_loading
from excavsim.tasks.truck_loading.recording import TruckLoadingRecorder
from tests.record.test_record import entities, rerun_cli

SPEC = "configs/specs/excavator_truck.yaml"
TRUCK_PARTS = ("chassis", "floor", "side_near", "side_far", "tailgate", "headboard", "cab")


class _Spy:
    """Hands every hook to the recorder, and keeps the world, the result and the bucket's true position at
    every control step (by simulated time) to hold the recording against."""

    def __init__(self, recorder: TruckLoadingRecorder):
        self.recorder, self.truth, self.world, self.result = recorder, {}, None, None

    def started(self, world, cfg):
        self.world, self.bucket = world, world.model.body("bucket").id
        self.truth[float(world.data.time)] = world.data.xpos[self.bucket].copy()
        self.recorder.started(world, cfg)

    def stepped(self, world):
        self.truth[float(world.data.time)] = world.data.xpos[self.bucket].copy()
        self.recorder.stepped(world)

    def scanned(self, *args):
        self.recorder.scanned(*args)

    def planned(self, *args):
        self.recorder.planned(*args)

    def dug(self, *args):
        self.recorder.dug(*args)

    def finished(self, result):
        self.result = result
        self.recorder.finished(result)


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    """One pass of the truck-loading spec, recorded through the command (the task's ``episode_recorder``)."""
    path = tmp_path_factory.mktemp("truckrec") / "truck.rrd"
    spies = []

    def recorder(p, *, live=None):
        spies.append(_Spy(TruckLoadingRecorder(p, live=live)))
        return spies[-1]

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(truck_loading, "episode_recorder", recorder)
        assert main(["run", SPEC, "--dig-budget", "1", "--record", str(path)]) == 0
    (spy,) = spies
    assert spy.result is not None and len(spy.result.passes) == 1
    return path, spy


def logged(path, entity: str, component: str) -> list[tuple[float, object]]:
    """The values of ``component`` (e.g. ``Transform3D:translation``) logged to ``entity`` on a timeline, in
    time order: (time, value) with the time of ``sim_time`` [s] or ``pass``."""
    rows = []
    for chunk in RrdReader(path).stream().to_chunks():
        if chunk.entity_path != entity or chunk.is_static:
            continue
        table = chunk.to_record_batch()
        col = next(c for c in table.schema.names if c.endswith(component))
        timeline = "sim_time" if "sim_time" in table.schema.names else "pass"
        ticks = table.column(timeline).cast(pa.int64()).to_pylist()  # sim_time in ns
        scale = 1e-9 if timeline == "sim_time" else 1
        for t, v in zip(ticks, table.column(col).to_pylist()):
            if v:
                rows.append((t * scale, v))
    return sorted(rows, key=lambda r: r[0])


def test_the_recording_passes_rerun_verify(recording):
    path, _ = recording
    done = subprocess.run([rerun_cli(), "rrd", "verify", str(path)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr


def test_the_recording_holds_the_machine_the_truck_the_fill_the_pit_and_the_metrics(recording):
    path, spy = recording
    ent = entities(path)
    steps = spy.world.data.time * 10.0  # sampled at 10 Hz over the episode
    for body in ("upper", "boom", "stick", "bucket"):
        assert ent[f"/world/excavator_25t/{body}"]["sim_time"] >= 0.9 * steps, body
    assert ent["/world/excavator_25t/cylinders"]["sim_time"] >= 0.9 * steps
    assert ent["/world/truck"]["static"] == 1  # the truck is parked: its pose once
    for part in TRUCK_PARTS:
        assert ent[f"/world/truck/truck_{part}"]["static"] == 1, part
    assert ent["/world/truck/fill"]["sim_time"] >= 3  # empty at the start, after the pass, at the end
    assert ent["/world/truck/scan"]["sim_time"] >= 2  # the looks before and after the pass
    assert ent["/world/soil/truth"]["sim_time"] >= 3
    assert ent["/world/pit/ground_front"]["static"] == 1
    for name in ("bucket_l", "truck_l", "spill_l", "cycle_s", "script_s", "cost"):
        assert ent[f"/pass/{name}"]["pass"] == 1, name
    assert ent["/soil/truck_l"]["sim_time"] >= 0.9 * steps and ent["/soil/bucket_l"]["sim_time"] >= 0.9 * steps


def _fill_m3(vertices, floor_m: float, cell_m: float) -> float:
    """The fill's volume from a logged fill mesh: a vertex per fill cell at the fill's surface."""
    return float((np.asarray(vertices, float)[:, 2] - floor_m).sum() * cell_m ** 2)


def test_the_logged_fill_and_metrics_are_the_worlds(recording):
    path, spy = recording
    w, (p,) = spy.world, spy.result.passes
    fills = logged(path, "/world/truck/fill", "Mesh3D:vertex_positions")
    assert len(fills[0][1]) == w.bed.nrows * w.bed.ncols
    assert _fill_m3(fills[0][1], w.truck.floor_m, w.bed.cell) == pytest.approx(0.0, abs=1e-9)  # empty at first
    last = _fill_m3(fills[-1][1], w.truck.floor_m, w.bed.cell)
    assert last > 0.5 and last == pytest.approx(w.bed.volume(), abs=1e-4)  # the bed's own account
    (truck_l,) = [v for _, v in logged(path, "/pass/truck_l", "Scalars:scalars")]
    (bucket_l,) = [v for _, v in logged(path, "/pass/bucket_l", "Scalars:scalars")]
    (cycle_s,) = [v for _, v in logged(path, "/pass/cycle_s", "Scalars:scalars")]
    assert truck_l[0] == pytest.approx(1000.0 * w.bed.volume(), rel=1e-9)
    assert bucket_l[0] == pytest.approx(1000.0 * p.bucket_m3, rel=1e-9)
    assert cycle_s[0] == pytest.approx(p.cycle_s, rel=1e-9)
    # the fill's vertices, put through the truck's logged frame, sit over the bed's inside in the world
    xyz = truck_frame(path) @ np.c_[np.asarray(fills[-1][1], float), np.ones(len(fills[-1][1]))].T
    assert w.bed.inside(xyz[0], xyz[1]).all()
    assert xyz[2] == pytest.approx(w.bed.surface_z().ravel(), abs=1e-5)


def truck_frame(path) -> np.ndarray:
    """The (3, 4) transform of the logged ``/world/truck`` frame (static) to the world."""
    for chunk in RrdReader(path).stream().to_chunks():
        if chunk.entity_path == "/world/truck" and chunk.is_static:
            table = chunk.to_record_batch()
            get = {c.split(":")[-1]: table.column(c).to_pylist()[0] for c in table.schema.names if ":" in c}
            (x, y, z, qw), t = (get["quaternion"][0] if "quaternion" in get else (0, 0, 0, 1)), get["translation"][0]
            rot = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * qw), 2 * (x * z + y * qw)],
                            [2 * (x * y + z * qw), 1 - 2 * (x * x + z * z), 2 * (y * z - x * qw)],
                            [2 * (x * z - y * qw), 2 * (y * z + x * qw), 1 - 2 * (x * x + y * y)]])
            return np.c_[rot, t]
    raise AssertionError("no static /world/truck transform in the recording")


def test_the_bucket_is_logged_where_the_world_has_it(recording):
    """The bucket's logged positions are the world's at the same simulated time, and they go from the dig to
    over the truck's bed: the recording shows the machine loading the truck."""
    path, spy = recording
    rows = logged(path, "/world/excavator_25t/bucket", "Transform3D:translation")
    times = np.array(sorted(spy.truth))
    assert len(rows) >= 0.9 * spy.world.data.time * 10.0
    for t, pos in rows:
        k = int(np.argmin(np.abs(times - t)))
        assert abs(times[k] - t) < 1e-6
        assert np.asarray(pos[0]) == pytest.approx(spy.truth[times[k]], abs=1e-5)
    pos = np.array([r[1][0] for r in rows])
    assert w_inside(spy.world, pos).any()  # it swung over the bed to dump
    bearing = np.arctan2(pos[:, 1], pos[:, 0])
    dig = spy.result.passes[0].dig_swing
    assert np.min(np.abs(bearing - dig)) < math.radians(2.0)  # and it was at the dig's bearing


def w_inside(world, pos: np.ndarray) -> np.ndarray:
    """Whether the positions lie over the bed's inside and above its floor."""
    return world.bed.inside(pos[:, 0], pos[:, 1]) & (pos[:, 2] > world.truck.floor_m)


def test_a_bad_file_is_refused(tmp_path):
    with pytest.raises(ExcavsimError, match="rrd"):
        TruckLoadingRecorder(tmp_path / "x.txt")
    with pytest.raises(ExcavsimError, match="rate_hz"):
        TruckLoadingRecorder(tmp_path / "x.rrd", rate_hz=0.0)
    rec = TruckLoadingRecorder(tmp_path / "y.rrd")
    with pytest.raises(ExcavsimError, match="before started"):
        rec.stepped(None)
    with pytest.raises(ExcavsimError, match="before started"):
        rec.dug(1, None)


def test_a_truck_that_leaves_takes_its_fill_off_the_recording(tmp_path):
    """When a full truck leaves (``TruckWorld.haul``) the fill is logged again, empty, at the next step."""
    from excavsim.tasks.truck_loading.world.truck import TruckWorld

    w = TruckWorld("excavator_25t", "dry_sand", seed=0)
    path = tmp_path / "haul.rrd"
    rec = TruckLoadingRecorder(path)
    rec.started(w, None)
    _, caught = w.bed.catch(np.array([w.truck.x_m]), np.array([w.truck.y_m]), np.array([0.5]), 0.6)
    assert caught == pytest.approx(0.5)
    q = w.joint_angles()
    while w.data.time < 0.3:
        w.step(q)
        rec.stepped(w)
    w.haul()
    hauled_at = float(w.data.time)
    while w.data.time < 0.6:
        w.step(q)
        rec.stepped(w)
    rec.finished(None)
    fills = logged(path, "/world/truck/fill", "Mesh3D:vertex_positions")
    assert len(fills) == 3  # the empty bed at the start, the new truck's at the first step after the haul, the end
    assert fills[1][0] == pytest.approx(hauled_at, abs=0.05)
    assert all(_fill_m3(f, w.truck.floor_m, w.bed.cell) == pytest.approx(0.0, abs=1e-9) for _, f in fills)
    truck_l = np.array([v[0] for _, v in logged(path, "/soil/truck_l", "Scalars:scalars")])
    assert truck_l.max() == pytest.approx(500.0, rel=1e-9) and truck_l[-1] == 0.0
