"""Rerun recordings of an excavator in its pit (``models/tb035``, ``models/excavator_25t`` in
:class:`~excavsim.world.hydraulics.ExcavatorWorld`): the machine's bodies and cylinders, and the soil.

:class:`ExcavatorRecorder` observes a run step by step (``started(world)``, ``stepped(world)`` after every
control step, ``finished(world)``): the teleoperation of ``excavsim playback --machine tb035 --teleop
--record FILE.rrd``, or any loop that steps the world (the ``excavsim/ExcavatorJoint-v0`` environment's
world is ``env.unwrapped.sim``). Timeline ``sim_time`` (duration). Entity tree::

    world                        ViewCoordinates (right-handed, z up), static
      <machine>/<body>           Transform3D of each moving body (xpos/xquat) at rate_hz; static for the base
      <machine>/<body>/<geom>    the visual geoms in the body frame (boxes, capsules, ...), static
      <machine>/cylinders        LineStrips3D: each cylinder pin to pin (its tendon), at rate_hz
      pit/<geom>                 the ground slabs around the pit, static
      soil/truth                 Mesh3D of the true heightfield at the start, every soil_period_s and at the end
    joint_deg/<function>         swing, boom, stick, bucket angles [deg], rate_hz
    cylinder_kn/<function>       swing torque [kN m] and cylinder forces [kN] (positive pushes), rate_hz
    soil/bucket_l                soil in the bucket [l] (truth), rate_hz
    soil/force_n                 |soil force on the bucket| [N] (truth), rate_hz
"""

from __future__ import annotations

import os
import pathlib

import mujoco
import numpy as np
import rerun as rr

from excavsim import constants
from excavsim.errors import ConfigError, UsageError
from excavsim.record.geometry import SAND_RGB, geom_archetype, grid_normals, grid_triangles, quat_xyzw
from excavsim.record.recorder import recording_id_for

FUNCTIONS = ("swing", "boom", "stick", "bucket")
FUNCTION_RGB = ((31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40))
CYLINDER_RGB = (170, 170, 180)


class ExcavatorRecorder:
    """Records one excavator run to ``path`` (an ``.rrd`` file; parent folders are created).

    Args:
        path: the recording to write; an existing file is replaced.
        rate_hz: how often the machine's pose and the signals are sampled [Hz of simulated time].
        soil_period_s: how often the true terrain is logged [s of simulated time].
        seed: the run's seed (part of the recording id).

    Raises:
        ExcavsimError: not an ``.rrd`` path, a rate or period that is not positive, or a second start.
    """

    def __init__(self, path: str | os.PathLike, *, rate_hz: float = 10.0, soil_period_s: float = 1.0, seed: int = 0):
        self.path = pathlib.Path(path)
        if self.path.suffix != ".rrd":
            raise ConfigError(f"an excavator recording must be an .rrd file; given {str(path)!r}")
        if not (np.isfinite(rate_hz) and rate_hz > 0 and np.isfinite(soil_period_s) and soil_period_s > 0):
            raise ConfigError(f"ExcavatorRecorder: rate_hz and soil_period_s must be positive numbers; given "
                              f"{rate_hz!r}, {soil_period_s!r}")
        self.rate_hz, self.soil_period_s, self.seed = float(rate_hz), float(soil_period_s), int(seed)
        self.rec: rr.RecordingStream | None = None
        self._next_t = self._next_soil = 0.0

    def started(self, world) -> None:
        """Open the file and log the static scene (geoms, pit) and the first sample."""
        if self.rec is not None:
            raise UsageError(f"an ExcavatorRecorder records one run; make a new one for {self.path}")
        m = world.model
        self.machine = world.spec.name
        rec = rr.RecordingStream("excavsim", recording_id=recording_id_for(self.path.name, self.seed,
                                                                           self._config_text(world)),
                                 send_properties=False)
        rec.set_log_time_enabled(False)
        rec.set_log_tick_enabled(False)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._open(rec)
        rec.send_recording_name(self.path.stem)
        self.rec = rec
        rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        self._names = {b: m.body(b).name or f"body_{b}" for b in range(m.nbody)}
        self._pit = m.body(constants.SOIL_BOX_BODY).id
        self._moving = [b for b in range(1, m.nbody) if b != self._pit and self._moves(m, b)]
        self._tendons = [m.tendon(f"{f}_cylinder").id for f in FUNCTIONS[1:]]
        for g in range(m.ngeom):
            b = int(m.geom_bodyid[g])
            if b == 0 or m.geom_group[g] == 3 or m.geom_type[g] == mujoco.mjtGeom.mjGEOM_HFIELD:
                continue  # collision geoms, the soil (logged as terrain)
            archetype = geom_archetype(m, g)
            if archetype is not None:
                rec.log(f"{self._root(b)}/{m.geom(g).name or f'geom_{g}'}", archetype, static=True)
        d = world.data
        for b in range(1, m.nbody):
            if b not in self._moving:
                rec.log(self._root(b), rr.Transform3D(translation=d.xpos[b], quaternion=quat_xyzw(d.xquat[b])),
                        static=True)
        for f, colour in zip(FUNCTIONS, FUNCTION_RGB):
            rec.log(f"joint_deg/{f}", rr.SeriesLines(names=f"{f} [deg]", colors=colour), static=True)
            unit = "kN m" if f == "swing" else "kN"
            rec.log(f"cylinder_kn/{f}", rr.SeriesLines(names=f"{f} [{unit}]", colors=colour), static=True)
        rec.log("soil/bucket_l", rr.SeriesLines(names="soil in the bucket [l]", colors=(245, 160, 40)), static=True)
        rec.log("soil/force_n", rr.SeriesLines(names="|soil force on the bucket| [N]", colors=(250, 250, 250)),
                static=True)
        self._next_t = self._next_soil = float(d.time)
        self.stepped(world)

    def _config_text(self, world) -> str:
        """What makes the run (part of the recording id)."""
        return f"machine: {self.machine}\nseed: {self.seed}\n"

    def _open(self, rec: rr.RecordingStream) -> None:
        """Point the stream at the file."""
        rec.set_sinks(rr.FileSink(str(self.path)))

    @staticmethod
    def _moves(m, b: int) -> bool:
        """Whether body ``b`` or one of its ancestors has a joint."""
        while b > 0:
            if m.body_jntnum[b] > 0:
                return True
            b = int(m.body_parentid[b])
        return False

    def _root(self, b: int) -> str:
        return "world/pit" if b == self._pit else f"world/{self.machine}/{self._names[b]}"

    def stepped(self, world) -> None:
        """After a control step: a sample of the machine and the signals when ``rate_hz`` says so, and the
        terrain every ``soil_period_s``."""
        if self.rec is None:
            raise UsageError("ExcavatorRecorder.stepped before started")
        t = float(world.data.time)
        if t + 1e-9 >= self._next_t:
            self._next_t += 1.0 / self.rate_hz * max(1, int((t - self._next_t) * self.rate_hz) + 1)
            self._sample(world, t)
        if t + 1e-9 >= self._next_soil:
            self._next_soil = t + self.soil_period_s
            self._terrain(world, t)

    def _sample(self, world, t: float) -> None:
        rec, d = self.rec, world.data
        rec.set_time("sim_time", duration=t)
        for b in self._moving:
            rec.log(self._root(b), rr.Transform3D(translation=d.xpos[b], quaternion=quat_xyzw(d.xquat[b])))
        strips = []
        for ten in self._tendons:
            adr, num = d.ten_wrapadr[ten], d.ten_wrapnum[ten]
            strips.append(d.wrap_xpos[adr:adr + num].reshape(-1, 3).copy())
        rec.log(f"world/{self.machine}/cylinders", rr.LineStrips3D(strips, colors=[CYLINDER_RGB] * len(strips),
                                                                     radii=0.02))
        q, forces = world.joint_angles(), world.cylinder_forces()
        for j, f in enumerate(FUNCTIONS):
            rec.log(f"joint_deg/{f}", rr.Scalars(float(np.degrees(q[j]))))
            rec.log(f"cylinder_kn/{f}", rr.Scalars(float(forces[j]) / 1000.0))
        rec.log("soil/bucket_l", rr.Scalars(1000.0 * float(world.soil.volumes().bucket)))
        wrench = world.contact.wrench if world.contact is not None else np.zeros(6)
        rec.log("soil/force_n", rr.Scalars(float(np.linalg.norm(wrench[:3]))))

    def _terrain(self, world, t: float) -> None:
        g = world.soil.grid
        h = g.heights
        xs, ys = np.meshgrid(g.x0 + np.arange(h.shape[1]) * g.cell, g.y0 + np.arange(h.shape[0]) * g.cell)
        verts = np.stack([xs, ys, h + g.z0], axis=-1).reshape(-1, 3).astype(np.float32)
        self.rec.set_time("sim_time", duration=t)
        self.rec.log("world/soil/truth", rr.Mesh3D(vertex_positions=verts, triangle_indices=grid_triangles(*h.shape),
                                                   vertex_normals=grid_normals(h, g.cell),
                                                   albedo_factor=SAND_RGB.astype(np.uint8)))

    def finished(self, world) -> None:
        """Log the last sample and terrain and close the file (complete, footer included)."""
        if self.rec is None:
            return
        t = float(world.data.time)
        self._sample(world, t)
        self._terrain(world, t)
        self.rec.flush()
        self.rec.disconnect()
        self.rec = None
