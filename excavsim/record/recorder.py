"""Rerun recordings of trenching episodes (the only module besides its helpers that imports rerun).

:class:`RerunRecorder` is an :class:`~excavsim.handoff.episode.EpisodeObserver` that writes one ``.rrd``
file per episode, headless, through its own :class:`rerun.RecordingStream` (never the global one, so
that several episodes recorded in one process stay apart). The file is complete, footer included,
when :meth:`RerunRecorder.finished` returns, also after an episode that raised. :func:`replay` opens
a recording in the Rerun viewer.

Timelines: ``sim_time`` (duration, simulated seconds) and ``dig`` (sequence: the cycle index, 0
before the first scan; cycle k scans, plans and digs dig k). Entity tree::

    world                      ViewCoordinates (right-handed, z up), static
      t3/<body>                Transform3D of each moving body (xpos/xquat) at rate_hz
      t3/<body>/<geom>         visual geoms in the body frame (Mesh3D, Boxes3D, Cylinders3D, ...), static
      box/<geom>               the soil box's walls, scanner mast and survey targets, static
      soil/truth               Mesh3D of the true heightfield at the start and after every dig
                               (red where the goal profile is over-dug)
      soil/scan                Mesh3D of each scanned elevation map (orange: cells filled, not observed)
      goal                     LineStrips3D: the goal profile (centre line and bucket-width edges)
      goal/footprint           Points3D: grid samples in the trench footprint at the goal height
      plan/path                LineStrips3D: the planned tip path (penetrate, drag, curl strips)
      exec/path                LineStrips3D: the tip path the executor measured while digging
    plan/feasible              Boxes3D of the planner's feasible cells, coloured by swept volume
    plan/chosen                the chosen cell (wireframe, labelled)
    plan/axes                  the axis ends of the (k, alpha, d1) grid, labelled
    ft/force/{x,y,z,norm}      wrist F/T force in the ft_mount frame [N] (noise-free), rate_hz
    ft/torque/{x,y,z}          wrist F/T moment [N m], rate_hz
    ft/tip/{x,y,z}             the executor's F/T readings in the tip frame [N] (what it sensed)
    torque/<actuator>          actuator torques [N m], rate_hz
    joint_deg/<actuator>       joint angles [deg], rate_hz
    truth/soil_force_n         magnitude of the soil's force on the bucket (truth) [N], rate_hz
    metrics/{predicted_l,bucket_l,efficiency,sim_s,removed_l,stall}   per dig
    metrics/map_rms_cm         per scan
    wall/planning_s            wall time the dig's planning took, per dig (the one entity that differs
                               between two recordings of the same episode)
    config                     TextDocument: the resolved configuration of the run, static
    log                        TextLog: scans, plans, digs and the end
    summary                    TextDocument: format_episode of the result (less its wall time), at the end

Reproducibility: the same episode (seed and configuration) recorded to files of the same name gives
the same recording id (:func:`recording_id_for`) and, decoded, the same rows on every entity but
``wall``. The files are not byte-identical: Rerun 0.41 stamps every row and chunk with an id made
of the wall time and a random number, and has no way to set them; the recording is written without
Rerun's recording properties (its start time).

A default blueprint (:func:`default_blueprint`) goes with the file: 3D views of the world with the
true terrain and with the map, the feasible set, time series of the signals and metrics, the summary.

What recording costs (wall time, file size per dig) is measured in the README's recording section.
"""

from __future__ import annotations

import hashlib
import os
import pathlib
import uuid

import mujoco
import numpy as np
import rerun as rr
import yaml

from excavsim import constants
from excavsim.errors import ExcavsimError
from excavsim.handoff.episode import DigMetrics, EpisodeObserver, EpisodeResult, format_episode
from excavsim.handoff.goal import goal_profile
from excavsim.record.blueprint import default_blueprint
from excavsim.record.geometry import (FILLED_RGB, MAP_RGB, OVERDIG_RGB, PHASE_NAMES, PHASE_RGB, PLAN_AXIS_LENGTH,
                                      SAND_RGB, geom_archetype, grid_normals, grid_triangles, quat_xyzw, ramp_colours)


def recording_id_for(name: str, seed: int, config_text: str) -> str:
    """The Rerun recording id of an episode recorded to a file called ``name``: a UUID derived from the
    file's name, the episode's ``seed`` and its resolved configuration (``config_text``), so that the
    same episode recorded again gets the same id, and two different ones never merge in one viewer."""
    digest = hashlib.sha256(config_text.encode()).hexdigest()
    return str(uuid.uuid5(uuid.NAMESPACE_URL, f"excavsim:{name}:seed {seed}:{digest}"))


class RerunRecorder(EpisodeObserver):
    """Records one episode to ``path`` (an ``.rrd`` file; parent folders are created).

    Args:
        path: the recording to write; an existing file is replaced.
        rate_hz: how often the robot's pose and the signals are sampled [Hz of simulated time].
        recording_id: Rerun's recording id (default: :func:`recording_id_for` the file's name, the
            episode's seed and its configuration).

    Raises:
        ExcavsimError: ``rate_hz`` is not positive, or the recorder is started a second time.
    """

    def __init__(self, path: str | os.PathLike, *, rate_hz: float = 10.0, recording_id: str | None = None):
        if not (np.isfinite(rate_hz) and rate_hz > 0):
            raise ExcavsimError(f"RerunRecorder rate_hz must be a positive number [Hz]; given {rate_hz!r}")
        self.path = pathlib.Path(path)
        self.rate_hz = float(rate_hz)
        self.recording_id = recording_id  # None: derived when the episode starts
        self.rec: rr.RecordingStream | None = None
        self._buffer: list[tuple] = []
        self._next_t = 0.0
        self._cycle = 0
        self._closed = False
        self._plan_axes_logged = False
        self.sim = self.rig = None

    # -- the observer hooks ---------------------------------------------------------------------
    def started(self, sim, rig, goal_mask: np.ndarray, goal_z: np.ndarray) -> None:
        if self.rec is not None:
            raise ExcavsimError(f"a RerunRecorder records one episode; make a new one for {self.path}")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        config = self._config_text(sim, rig)
        self.recording_id = self.recording_id or recording_id_for(self.path.name, sim.seed, config)
        # no recording properties: they hold the wall-clock start time
        rec = rr.RecordingStream("excavsim", recording_id=self.recording_id, send_properties=False)
        rec.set_log_time_enabled(False)  # reproducible files: only our own timelines
        rec.set_log_tick_enabled(False)
        rec.save(self.path, default_blueprint=default_blueprint())
        rec.send_recording_name(self.path.stem)
        self.rec, self.sim, self.rig = rec, sim, rig
        self.goal_mask, self.goal_z, self.h0 = goal_mask, goal_z, sim.soil.grid.heights.copy()
        self.waist = float(np.radians(rig.goal.waist_deg))
        m = sim.model
        self._moving = np.array([b for b in range(1, m.nbody) if m.body_weldid[b] != 0])
        self._names = {b: m.body(b).name or f"body_{b}" for b in range(m.nbody)}
        index = sim.index
        self._ft_adr = [index.ft_force, index.ft_torque]
        self._act = index.actuator
        self._qadr = index.qpos
        self._time(sim.time)
        rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        rec.log("plan", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        rec.log("config", rr.TextDocument(config, media_type=rr.MediaType.MARKDOWN), static=True)
        self._log_bodies(sim)
        self._log_series_styles()
        self._log_goal(sim, rig, goal_mask, goal_z)
        g = sim.soil.grid
        self._terrain_tris = grid_triangles(*g.shape)
        # Indices once (static); each later log only sends vertices, normals and colours.
        rec.log("world/soil/truth", rr.Mesh3D.from_fields(triangle_indices=self._terrain_tris), static=True)
        self._log_true_terrain()
        self._say(f"episode: goal {rig.goal.name or '(inline)'} at waist {rig.goal.waist_deg:g} deg, "
                  f"soil {sim.scene.soil}, recorded at {self.rate_hz:g} Hz")

    def scanned(self, index: int, emap, accuracy) -> None:
        self._flush()
        self._cycle = index
        self._time(self.sim.time)
        ny, nx = emap.shape
        xc, yc = emap.centres()
        xs, ys = np.meshgrid(xc, yc)
        verts = np.stack([xs, ys, emap.heights], axis=-1).reshape(-1, 3)
        colours = np.where(emap.observed.reshape(-1, 1), MAP_RGB, FILLED_RGB).astype(np.uint8)
        self.rec.log("world/soil/scan", rr.Mesh3D(
            vertex_positions=verts, triangle_indices=grid_triangles(ny, nx),
            vertex_normals=grid_normals(emap.heights, emap.cell), vertex_colors=colours))
        self.rec.log("metrics/map_rms_cm", rr.Scalars(100 * accuracy.rms_m))
        self._say(f"scan {index}: {accuracy.summary()}")

    def planned(self, index: int, plan, dig) -> None:
        self._flush()
        self._time(self.sim.time)
        if plan is not None:
            self._log_feasible(plan)
        self.rec.log("world/exec/path", rr.Clear(recursive=False))  # the last dig's path, until this one's
        if dig is None:
            self.rec.log("world/plan/path", rr.Clear(recursive=False))
            why = f" ({plan.reason}) and no fallback" if plan is not None else ""
            self._say(f"plan {index}: no dig{why}", level=rr.TextLogLevel.WARN)
            return
        strips, colours, labels = [], [], []
        points = self.rig.arm.plane_to_world(self.waist, dig.poses[:, :2])
        for p, name in enumerate(PHASE_NAMES):
            idx = np.flatnonzero(dig.phases == p)
            if idx.size:  # each phase's strip starts at the end of the one before, so the path is unbroken
                strips.append(points[max(idx[0] - 1, 0):idx[-1] + 1])
                colours.append(PHASE_RGB[p])
                labels.append(name)
        self.rec.log("world/plan/path", rr.LineStrips3D(strips, colors=colours, labels=labels, radii=0.008))
        if dig.action is None:
            why = f"{plan.reason}; " if plan is not None else ""
            self._say(f"plan {index}: {why}{dig.kind}, {1000 * dig.volume_m3:.1f} l")
        else:
            k, a, d1, d2 = dig.action
            how = f"{plan.reason}, " if plan is not None and dig.kind == "planned" else f"{dig.kind}, "
            self._say(f"plan {index}: k {k:.2f} m, alpha {np.degrees(a):.0f} deg, d1 {d1:.2f} m, d2 {d2:.2f} m, "
                      f"{1000 * dig.volume_m3:.1f} l ({how.removesuffix(', ')})")

    def stepped(self, sim) -> None:
        d, t = sim.data, sim.time
        if t + 1e-9 < self._next_t:
            return
        self._next_t = t + 1.0 / self.rate_hz
        fa, ta = self._ft_adr
        contact = sim.contact
        self._buffer.append((t, self._cycle, d.xpos[self._moving].copy(), d.xquat[self._moving].copy(),
                             d.sensordata[fa:fa + 3].copy(), d.sensordata[ta:ta + 3].copy(),
                             d.actuator_force[self._act].copy(), d.qpos[self._qadr].copy(),
                             float(np.linalg.norm(contact.force)) if contact is not None else 0.0))
        if len(self._buffer) >= 512:
            self._flush()

    def dug(self, index: int, record, metrics: DigMetrics) -> None:
        self._flush()
        self._time(self.sim.time)
        if record.executed_path:
            path = np.asarray(record.executed_path)
            self.rec.log("world/exec/path", rr.LineStrips3D(
                [self.rig.arm.plane_to_world(self.waist, path[:, :2])], colors=[(240, 240, 240)], radii=0.008))
        if record.ft:
            t = np.array([r[0] for r in record.ft])
            f = np.array([r[1] for r in record.ft])
            for i, axis in enumerate("xyz"):
                self.rec.send_columns(f"ft/tip/{axis}", indexes=[rr.TimeColumn("sim_time", duration=t)],
                                      columns=rr.Scalars.columns(scalars=f[:, i]))
        self._log_true_terrain()
        cell = self.sim.soil.grid.cell_area
        removed = float(np.clip(self.h0 - self.sim.soil.grid.heights, 0, None)[self.goal_mask].sum() * cell)
        values = {"predicted_l": 1000 * metrics.predicted_m3, "bucket_l": 1000 * metrics.bucket_m3,
                  "efficiency": metrics.efficiency, "sim_s": metrics.sim_s,
                  "removed_l": 1000 * removed, "stall": float(metrics.stall_joint is not None)}
        for name, value in values.items():
            self.rec.log(f"metrics/{name}", rr.Scalars(value))
        self.rec.log("wall/planning_s", rr.Scalars(metrics.planning_s))
        warn = metrics.stall_joint is not None or not record.completed
        self._say(f"dig {index} ({metrics.kind}): {record.outcome}, {1000 * metrics.predicted_m3:.1f} l planned, "
                  f"{1000 * metrics.bucket_m3:.1f} l dug, touch-down offset {100 * record.touch_offset_m:.1f} cm"
                  + (f", stall at {metrics.stall_joint}" if metrics.stall_joint else "")
                  + "".join(f"; {w}" for w in record.warnings),
                  level=rr.TextLogLevel.WARN if warn else rr.TextLogLevel.INFO)

    def finished(self, result: EpisodeResult | None) -> None:
        if self.rec is None or self._closed:
            return
        try:
            self._flush()
            self._time(self.sim.time)
            if result is None:
                text = "# Episode\n\nThe episode ended with an error; the log shows how far it got."
                self._say("the episode ended with an error", level=rr.TextLogLevel.ERROR)
            else:
                table = format_episode(result).replace(f" in {result.wall_time_s:.1f} s wall", "")  # reproducible
                text = f"# Episode\n\n```\n{table.strip()}\n```\n"
                self._say(f"ended: {result.reason}")
            self.rec.log("summary", rr.TextDocument(text, media_type=rr.MediaType.MARKDOWN))
        finally:
            self._closed = True
            self.rec.flush()
            self.rec.disconnect()  # closes the file and writes its footer

    # -- helpers --------------------------------------------------------------------------------
    def _time(self, t: float) -> None:
        self.rec.set_time("sim_time", duration=float(t))
        self.rec.set_time("dig", sequence=self._cycle)

    def _say(self, text: str, *, level: str = rr.TextLogLevel.INFO) -> None:
        self.rec.log("log", rr.TextLog(text, level=level))

    def _flush(self) -> None:
        """Send the buffered samples of :meth:`stepped` as columns (one chunk per entity)."""
        if not self._buffer:
            return
        t, cycle, xpos, xquat, force, torque, tau, q, soil = (np.asarray(c) for c in zip(*self._buffer))
        self._buffer.clear()
        times = rr.TimeColumn("sim_time", duration=t)
        both = [times, rr.TimeColumn("dig", sequence=cycle)]
        send = self.rec.send_columns
        quat = quat_xyzw(xquat)
        for i, b in enumerate(self._moving):
            send(f"world/t3/{self._names[b]}", indexes=both,
                 columns=rr.Transform3D.columns(translation=xpos[:, i], quaternion=quat[:, i]))
        for i, axis in enumerate("xyz"):
            send(f"ft/force/{axis}", indexes=[times], columns=rr.Scalars.columns(scalars=force[:, i]))
            send(f"ft/torque/{axis}", indexes=[times], columns=rr.Scalars.columns(scalars=torque[:, i]))
        send("ft/force/norm", indexes=[times],
             columns=rr.Scalars.columns(scalars=np.linalg.norm(force, axis=1)))
        for j, name in enumerate(constants.ACTUATORS):
            send(f"torque/{name}", indexes=[times], columns=rr.Scalars.columns(scalars=tau[:, j]))
            send(f"joint_deg/{name}", indexes=[times], columns=rr.Scalars.columns(scalars=np.degrees(q[:, j])))
        send("truth/soil_force_n", indexes=[times], columns=rr.Scalars.columns(scalars=soil))

    def _log_bodies(self, sim) -> None:
        """Each body's visual geoms, static in the body frame; a static pose for the fixed bodies."""
        m, d = sim.model, sim.data
        base = m.body(constants.SOIL_BOX_BODY).id
        for g in range(m.ngeom):
            b = int(m.geom_bodyid[g])
            if b == 0 or m.geom_group[g] == 3 or m.geom_type[g] == mujoco.mjtGeom.mjGEOM_HFIELD:
                continue  # the world's floor, collision geoms, the soil (logged as terrain)
            archetype = geom_archetype(m, g)
            if archetype is None:
                continue
            root = "world/box" if b == base else f"world/t3/{self._names[b]}"
            self.rec.log(f"{root}/{m.geom(g).name or f'geom_{g}'}", archetype, static=True)
        for b in range(1, m.nbody):
            if b not in self._moving:
                root = "world/box" if b == base else f"world/t3/{self._names[b]}"
                self.rec.log(root, rr.Transform3D(translation=d.xpos[b], quaternion=quat_xyzw(d.xquat[b])),
                             static=True)

    def _log_series_styles(self) -> None:
        rgb = ((220, 60, 60), (60, 170, 60), (60, 100, 220))
        for i, axis in enumerate("xyz"):
            self.rec.log(f"ft/force/{axis}", rr.SeriesLines(names=f"F{axis} [N]", colors=rgb[i]), static=True)
            self.rec.log(f"ft/torque/{axis}", rr.SeriesLines(names=f"M{axis} [N m]", colors=rgb[i]),
                         static=True)
            self.rec.log(f"ft/tip/{axis}", rr.SeriesPoints(names=f"tip F{axis} [N]", colors=rgb[i]),
                         static=True)
        self.rec.log("ft/force/norm", rr.SeriesLines(names="|F| [N]", colors=(40, 40, 40)), static=True)
        self.rec.log("truth/soil_force_n", rr.SeriesLines(names="soil on bucket |F| [N]"), static=True)
        for name in constants.ACTUATORS:
            self.rec.log(f"torque/{name}", rr.SeriesLines(names=f"{name} [N m]"), static=True)
            self.rec.log(f"joint_deg/{name}", rr.SeriesLines(names=f"{name} [deg]"), static=True)
        for name in ("metrics/predicted_l", "metrics/bucket_l", "metrics/efficiency", "wall/planning_s",
                     "metrics/sim_s", "metrics/removed_l", "metrics/stall", "metrics/map_rms_cm"):
            label = name.split("/")[1]
            self.rec.log(name, rr.SeriesLines(names=label), rr.SeriesPoints(names=label), static=True)

    def _log_goal(self, sim, rig, goal_mask: np.ndarray, goal_z: np.ndarray) -> None:
        goal, arm = rig.goal, rig.arm
        x = np.linspace(goal.near_x_m - 0.2, goal.far_x_m + 0.2, 100)
        centre = arm.plane_to_world(self.waist, np.stack([x, goal_profile(goal, x)], axis=-1))
        along = centre[-1, :2] - centre[0, :2]
        across = np.r_[-along[1], along[0], 0.0] / np.linalg.norm(along) * rig.width / 2
        strips = [centre - across, centre, centre + across]
        self.rec.log("world/goal", rr.LineStrips3D(strips, colors=[(60, 200, 90)] * 3, radii=[0.004, 0.006, 0.004],
                                                   labels=["", goal.name or "goal", ""]), static=True)
        g = sim.soil.grid
        rows, cols = np.nonzero(goal_mask)
        gx, gy = g.xy(rows, cols)
        # The goal profile is a world height, as the map's (the box floor is at z0 = 0 in the scene).
        self.rec.log("world/goal/footprint", rr.Points3D(np.stack([gx, gy, goal_z[rows, cols]], axis=-1),
                                                         colors=(60, 200, 90), radii=0.006), static=True)

    def _log_true_terrain(self) -> None:
        g = self.sim.soil.grid
        h = g.heights
        xs, ys = np.meshgrid(g.x0 + np.arange(h.shape[1]) * g.cell, g.y0 + np.arange(h.shape[0]) * g.cell)
        verts = np.stack([xs, ys, h + g.z0], axis=-1).reshape(-1, 3).astype(np.float32)
        depth = np.clip(self.rig.goal.surface_z_m - h, 0, 1).reshape(-1, 1)
        colours = SAND_RGB * (1 - 0.8 * np.minimum(depth / 0.3, 1))  # darker with depth below the surface
        over = (self.goal_mask & (h < self.goal_z - 0.01)).reshape(-1)
        colours[over] = OVERDIG_RGB
        self.rec.log("world/soil/truth", rr.Mesh3D.from_fields(
            vertex_positions=verts, vertex_normals=grid_normals(h, g.cell), vertex_colors=colours.astype(np.uint8)))

    def _log_feasible(self, plan) -> None:
        axes = (np.asarray(plan.grid_k), np.degrees(plan.grid_alpha), np.asarray(plan.grid_d1))
        lows = np.array([a.min() for a in axes])
        steps = np.array([np.min(np.diff(a)) if a.size > 1 else 1.0 for a in axes])
        scale = PLAN_AXIS_LENGTH / np.maximum(np.array([a.max() for a in axes]) - lows, steps)
        if not self._plan_axes_logged:
            self._plan_axes_logged = True
            ends = np.array([[0, 0, 0], [PLAN_AXIS_LENGTH, 0, 0], [0, PLAN_AXIS_LENGTH, 0], [0, 0, PLAN_AXIS_LENGTH]])
            labels = ["", f"k {axes[0].max():.2f} m", f"alpha {axes[1].max():.0f} deg", f"d1 {axes[2].max():.2f} m"]
            labels[0] = f"k {lows[0]:.2f} m, alpha {lows[1]:.0f} deg, d1 {lows[2]:.2f} m"
            self.rec.log("plan/axes", rr.LineStrips3D([[ends[0], e] for e in ends[1:]], colors=[(200, 200, 200)] * 3),
                         rr.Points3D(ends, labels=labels, radii=0.01), static=True)
        cells = np.argwhere(plan.feasible)
        centres = np.stack([(axes[i][cells[:, i]] - lows[i]) * scale[i] for i in range(3)], axis=-1)
        volume = np.nan_to_num(plan.volume[plan.feasible]) * 1000
        cap = self.rig.capacity * 1000
        self.rec.log("plan/feasible", rr.Boxes3D(
            centers=centres, half_sizes=np.tile(0.42 * steps * scale, (len(cells), 1)),
            colors=ramp_colours(volume / cap), fill_mode=rr.components.FillMode.Solid,
            labels=[f"{v:.1f} l" for v in volume], show_labels=False))
        if plan.action is None:
            self.rec.log("plan/chosen", rr.Clear(recursive=False))
            return
        k, a, d1, _ = plan.action
        idx = [int(np.argmin(np.abs(axes[i] - v))) for i, v in enumerate((k, np.degrees(a), d1))]
        centre = [(axes[i][idx[i]] - lows[i]) * scale[i] for i in range(3)]
        self.rec.log("plan/chosen", rr.Boxes3D(
            centers=[centre], half_sizes=[0.6 * steps * scale], colors=[(255, 40, 40)],
            labels=[f"chosen: k {k:.2f} m, alpha {np.degrees(a):.0f} deg, d1 {d1:.2f} m, "
                    f"{1000 * plan.volume_m3:.1f} l"], radii=0.006))

    @staticmethod
    def _config_text(sim, rig) -> str:
        parts = {"goal": rig.goal, "robot": sim.robot, "scene": sim.scene, "planner": rig.planner_cfg,
                 "executor": rig.executor_cfg, "sensing": rig.sensing_cfg}
        dumped = {name: cfg.model_dump(mode="json") for name, cfg in parts.items()}
        return f"# Resolved configuration\n\n```yaml\n{yaml.safe_dump(dumped, sort_keys=False)}```\n"
