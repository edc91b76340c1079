"""Rerun recording of a MuJoCo loading episode (excavsim load --mujoco --record FILE.rrd).

An observer of :func:`excavsim.tasks.load.task.run_episode` (the loop never imports it). Entities:
``world`` (right-handed, z up, static); ``world/<machine>/<body>`` the machine's visual geoms, static in
their body frames, and a ``Transform3D`` per sample; ``world/box`` the lane's kerbs; ``world/soil/truth``
(the true terrain, a ``Mesh3D`` grid whose indices are logged once) after every scan and dig;
``world/soil/scan`` the elevation map; ``world/plan/path`` the planned tip path (pre-entry, approach, arc,
lift-out) and ``world/exec/path`` the executed one, as ``LineStrips3D``; scalars ``volumes/*`` (lane,
bucket, spoil [m^3]: their sum is constant; the spoil is the delivered and the spilled soil, which the
log's dig lines give apart), ``truth/soil_force_n`` and ``joints/*`` sent with
``send_columns``; ``log`` as ``TextLog``. Timelines ``sim_time`` (duration) and ``dig`` (sequence).
"""

from __future__ import annotations

import os
import pathlib

import mujoco
import numpy as np
import rerun as rr

from excavsim.errors import ConfigError, UsageError
from excavsim.record.geometry import MAP_RGB, SAND_RGB, geom_archetype, grid_normals, grid_triangles, quat_xyzw

PLAN_RGB = (230, 90, 40)


class LoadingRecorder:
    """Records one MuJoCo loading episode to ``path`` at ``rate_hz`` of simulated time."""

    def __init__(self, path: str | os.PathLike, *, rate_hz: float = 10.0, recording_id: str | None = None):
        if not (np.isfinite(rate_hz) and rate_hz > 0):
            raise ConfigError(f"LoadingRecorder rate_hz must be a positive number [Hz]; given {rate_hz!r}")
        self.path = pathlib.Path(path)
        self.rate_hz = float(rate_hz)
        self.recording_id = recording_id
        self.rec: rr.RecordingStream | None = None
        self._buffer: list[tuple] = []
        self._next_t = 0.0
        self._dig = 0

    def started(self, world, machine: str) -> None:
        if self.rec is not None:
            raise UsageError(f"a LoadingRecorder records one episode; make a new one for {self.path}")
        rec = rr.RecordingStream("excavsim", recording_id=self.recording_id or f"load-{machine}-{self.path.stem}",
                                 send_properties=False)
        rec.set_log_time_enabled(False)
        rec.set_log_tick_enabled(False)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        rec.save(str(self.path))
        self.rec, self.world, self.machine = rec, world, machine
        m, d = world.model, world.data
        self._moving = np.array([b for b in range(1, m.nbody) if m.body_weldid[b] != 0])
        box = m.body("soil_box").id
        rec.set_time("sim_time", duration=world.time)
        rec.set_time("dig", sequence=0)
        rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        for g in range(m.ngeom):
            b = int(m.geom_bodyid[g])
            if b == 0 or m.geom_type[g] == mujoco.mjtGeom.mjGEOM_HFIELD:
                continue
            arch = geom_archetype(m, g)
            if arch is not None:
                rec.log(f"{self._root(b, box)}/{m.geom(g).name or f'geom_{g}'}", arch, static=True)
        for b in range(1, m.nbody):
            if b not in self._moving:
                rec.log(self._root(b, box), rr.Transform3D(translation=d.xpos[b], quaternion=quat_xyzw(d.xquat[b])),
                        static=True)
        g = world.soil.grid
        self._tris = grid_triangles(*g.shape)
        rec.log("world/soil/truth", rr.Mesh3D.from_fields(triangle_indices=self._tris), static=True)
        self._log_truth()
        rec.log("log", rr.TextLog(f"loading episode: front {machine}, lane {world.volumes().box:.3f} m^3 of soil"))

    def _root(self, b: int, box: int) -> str:
        return "world/box" if b == box else f"world/{self.machine}/{self.world.model.body(b).name or f'body_{b}'}"

    def scanned(self, index: int, emap, terrain) -> None:
        self._flush()
        self.rec.set_time("sim_time", duration=self.world.time)
        ny, nx = emap.shape
        xc, yc = emap.centres()
        xs, ys = np.meshgrid(xc, yc)
        verts = np.stack([xs, ys, emap.heights], axis=-1).reshape(-1, 3)
        self.rec.log("world/soil/scan", rr.Mesh3D(vertex_positions=verts, triangle_indices=grid_triangles(ny, nx),
                                                  vertex_normals=grid_normals(emap.heights, emap.cell),
                                                  vertex_colors=np.tile(MAP_RGB.astype(np.uint8), (ny * nx, 1))))
        self._log_truth()

    def planned(self, index: int, plan, poses: np.ndarray) -> None:
        self._dig = index
        self.rec.set_time("dig", sequence=self._dig)
        a = plan.action
        pts = np.stack([poses[:, 0], np.zeros(len(poses)), poses[:, 1]], axis=1)
        self.rec.log("world/plan/path", rr.LineStrips3D([pts], colors=[PLAN_RGB], radii=0.02,
                                                        labels=[f"plan {self._dig}"]))
        self.rec.log("world/exec/path", rr.Clear(recursive=False))
        self.rec.log("log", rr.TextLog(f"plan {self._dig}: k {a.k:.2f} m, h {a.h:.2f} m, alpha "
                                       f"{np.degrees(a.alpha):.0f} deg, d1 {a.d1:.2f} m, r {a.r:.2f} m, "
                                       f"{plan.volume:.3f} m^2 of the section ({plan.reason})"))

    def stepped(self, world) -> None:
        t = world.time
        if t + 1e-9 < self._next_t:
            return
        self._next_t = t + 1.0 / self.rate_hz
        d = world.data
        v = world.volumes()
        force = float(np.linalg.norm(world.contact.force)) if world.contact is not None else 0.0
        self._buffer.append((t, d.xpos[self._moving].copy(), d.xquat[self._moving].copy(), world.joint_angles(),
                             (v.box, v.bucket, v.spoil, v.total), force))
        if len(self._buffer) >= 512:
            self._flush()

    def dug(self, index: int, dig) -> None:
        self._flush()
        self.rec.set_time("sim_time", duration=self.world.time)
        if len(dig.tip_path):
            p = dig.tip_path
            self.rec.log("world/exec/path", rr.LineStrips3D([np.stack([p[:, 0], np.zeros(len(p)), p[:, 1]], 1)],
                                                            colors=[(240, 240, 240)], radii=0.02))
        self.rec.log("log", rr.TextLog(f"dig {index}: planned {dig.planned_m3:.3f} m^3, in the bucket at lift-out "
                                       f"{dig.bucket_m3:.3f}, delivered {dig.delivered_m3:.3f}, spilled "
                                       f"{dig.spilled_m3:.3f}, lane {dig.lane_m3:.3f} ({dig.section} section)"))
        self._log_truth()

    def finished(self, run) -> None:
        self._flush()
        if run is None:  # the episode ended with an error: what was recorded is kept
            self.rec.log("log", rr.TextLog("end: the episode ended with an error"))
            self.rec.flush()
            self.rec.disconnect()
            return
        self.rec.log("log", rr.TextLog(f"end: {run.reason}; lane {run.start_m3:.3f} -> {run.end_m3:.3f} m^3, "
                                       f"{len(run.digs)} digs"))
        self.rec.flush()
        self.rec.disconnect()

    def _log_truth(self) -> None:
        g = self.world.soil.grid
        h = g.heights
        xs, ys = np.meshgrid(g.x0 + np.arange(h.shape[1]) * g.cell, g.y0 + np.arange(h.shape[0]) * g.cell)
        verts = np.stack([xs, ys, h + g.z0], axis=-1).reshape(-1, 3).astype(np.float32)
        colours = np.tile(SAND_RGB.astype(np.uint8), (h.size, 1))
        self.rec.log("world/soil/truth", rr.Mesh3D.from_fields(vertex_positions=verts,
                                                               vertex_normals=grid_normals(h, g.cell),
                                                               vertex_colors=colours))

    def _flush(self) -> None:
        if not self._buffer:
            return
        rec, m = self.rec, self.world.model
        times = np.array([b[0] for b in self._buffer])
        pos = np.stack([b[1] for b in self._buffer])
        quat = np.stack([b[2] for b in self._buffer])
        box = m.body("soil_box").id
        tcol = rr.TimeColumn("sim_time", duration=times)
        for i, b in enumerate(self._moving):
            rec.send_columns(self._root(int(b), box), indexes=[tcol],
                             columns=rr.Transform3D.columns(translation=pos[:, i], quaternion=quat_xyzw(quat[:, i])))
        q = np.stack([b[3] for b in self._buffer])
        for j, name in enumerate(self.world.joints):
            rec.send_columns(f"joints/{name.removesuffix('_joint')}", indexes=[tcol],
                             columns=rr.Scalars.columns(scalars=q[:, j]))
        vol = np.array([b[4] for b in self._buffer])
        for j, name in enumerate(("lane", "bucket", "spoil", "total")):
            rec.send_columns(f"volumes/{name}_m3", indexes=[tcol], columns=rr.Scalars.columns(scalars=vol[:, j]))
        rec.send_columns("truth/soil_force_n", indexes=[tcol],
                         columns=rr.Scalars.columns(scalars=np.array([b[5] for b in self._buffer])))
        self._buffer.clear()
