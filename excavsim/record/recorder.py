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
      goal/name                Points3D: the goal's name, at the far end of the centre line
      goal/footprint           Points3D: grid samples in the trench footprint at the goal height
      plan/path                LineStrips3D: the planned tip path (penetrate, drag, curl strips; one label)
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
    notes                      TextDocument: how to read the recording (clipped plots, colours), static
    log                        TextLog: scans, plans, digs, servo-saturated intervals (warnings) and the end
    summary                    TextDocument at the start, after every dig (a growing per-dig table) and
                               at the end (why it ended, the trench against the goal; no wall time)

Reproducibility: the same episode (seed and configuration) recorded to files of the same name gives
the same recording id (:func:`recording_id_for`) and, decoded, the same rows on every entity but
``wall``. The files are not byte-identical: Rerun 0.41 stamps every row and chunk with an id made
of the wall time and a random number, and has no way to set them; the recording is written without
Rerun's recording properties (its start time).

A default blueprint (:func:`default_blueprint`) goes with the file: 3D views of the world with the
true terrain and with the map (the camera on the trench, :func:`trench_camera`), the feasible set,
time series of the signals (force plots on fixed ranges that show digging) and metrics, the summary.
With ``live``, the same stream also goes to a viewer as the episode runs.

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
from excavsim.errors import ConfigError, UsageError
from excavsim.handoff.episode import DigMetrics, EpisodeObserver, EpisodeResult
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


SATURATED = 0.999  # a servo whose |torque| is at least this fraction of its limit is saturated
XYZ_RGB = ((235, 80, 70), (90, 200, 90), (80, 140, 250))
ACTUATOR_RGB = ((31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40), (148, 103, 189), (227, 119, 194))
METRIC_SERIES = {  # entity: (series name with its unit, colour)
    "metrics/predicted_l": ("planned [l]", (120, 160, 230)),
    "metrics/bucket_l": ("dug, in the bucket [l]", (245, 160, 40)),
    "metrics/removed_l": ("removed so far, cumulative [l]", (90, 200, 90)),
    "metrics/efficiency": ("efficiency, dug / planned [-]", (245, 160, 40)),
    "metrics/stall": ("stall [0 or 1]", (235, 80, 70)),
    "metrics/sim_s": ("dig duration [s simulated]", (120, 160, 230)),
    "wall/planning_s": ("planning [s wall]", (245, 160, 40)),
    "metrics/map_rms_cm": ("map RMS error [cm]", (120, 160, 230)),
}
NOTES = """# How to read this recording

* **Timelines**: `sim_time` (simulated seconds) and `dig` (the cycle: scan, plan and dig k).
* **Forces**: *forces while digging* shows what the executor sensed at the bucket tip (points, only
  during digs) and the true soil force on the bucket (white line). The wrist F/T plots hold the
  sensor's reading in its own frame, bucket weight included (~275 N at rest). All force plots have
  fixed ranges (-1 to 1.5 kN, +-1.5 kN, +-1 kN m): while a servo is at its torque limit (the park
  move at the start, fast moves between digs) the wrist reads up to ~14 kN of the arm's own inertia;
  those spikes are clipped, and the log names each such interval and its peak. Scroll or
  double-click a plot to see its whole range.
* **Planned path**: penetrate (orange), drag (yellow), curl (blue); the measured path is white.
* **Terrain**: sand coloured darker with depth, red where the goal is over-dug; the scanned map is
  blue, orange where cells were filled, not observed.
* **Soil [l]**: planned and dug are per dig; *removed so far* is cumulative (the goal's footprint).
* **Summary**: grows after every dig; the episode's end is added when it ends.
"""


def trench_camera(rig) -> tuple[np.ndarray, np.ndarray]:
    """Where the 3-D views' camera starts and what it looks at: the middle of the trench, seen from
    the side of the arm plane and above, so that the trench, the bucket and the spoil fill the view."""
    goal, arm = rig.goal, rig.arm
    waist = float(np.radians(goal.waist_deg))
    near, mid, far = arm.plane_to_world(waist, np.array([[goal.near_x_m, goal.surface_z_m],
                                                          [(goal.near_x_m + goal.far_x_m) / 2, goal.surface_z_m],
                                                          [goal.far_x_m, goal.surface_z_m]]))
    along = (far - near) / max(np.linalg.norm(far - near), 1e-9)
    across = np.array([-along[1], along[0], 0.0])
    # beside the arm plane, behind the trench's middle towards the robot, and above [m]
    eye = mid - 2.6 * across - 0.9 * along + np.array([0.0, 0.0, 1.9])
    return eye, mid - np.array([0.0, 0.0, 0.1])


def episode_end_text(result: EpisodeResult) -> str:
    """The end of an episode in a few short lines (markdown): why it ended, the trench against the
    goal, the digs' failures. No wall time, so that two recordings of one episode hold the same text."""
    digs = result.digs
    return (f"**Ended**: {result.reason}.\n\n"
            f"Removed {1000 * result.removed_m3:.1f} l of {1000 * result.goal_m3:.1f} l "
            f"({100 * result.removed_fraction:.0f} %); over-dig max {100 * result.overdig_max_m:.1f} cm "
            f"(RMS {100 * result.overdig_rms_m:.1f}), under-dig max {100 * result.underdig_max_m:.1f} cm "
            f"(RMS {100 * result.underdig_rms_m:.1f}).\n\n"
            f"{len(digs)} digs, {sum(d.stall_joint is not None for d in digs)} stalls, "
            f"{sum(d.failed for d in digs)} failed; {result.sim_time_s:.0f} s simulated.")


class RerunRecorder(EpisodeObserver):
    """Records one episode to ``path`` (an ``.rrd`` file; parent folders are created).

    Args:
        path: the recording to write; an existing file is replaced. None: no file (``live`` only).
        rate_hz: how often the robot's pose and the signals are sampled [Hz of simulated time].
        recording_id: Rerun's recording id (default: :func:`recording_id_for` the file's name, the
            episode's seed and its configuration).
        live: also stream the episode, as it runs, to the viewer at this gRPC URL
            (``rerun+http://HOST:PORT/proxy``; see :func:`excavsim.record.live.viewer_url`).

    Raises:
        ExcavsimError: ``rate_hz`` is not positive, neither ``path`` nor ``live`` is given, or the
            recorder is started a second time.
    """

    def __init__(self, path: str | os.PathLike | None, *, rate_hz: float = 10.0, recording_id: str | None = None,
                 live: str | None = None):
        if not (np.isfinite(rate_hz) and rate_hz > 0):
            raise ConfigError(f"RerunRecorder rate_hz must be a positive number [Hz]; given {rate_hz!r}")
        if path is None and not live:
            raise UsageError("RerunRecorder needs a file to write (path) or a viewer to stream to (live)")
        self.path = pathlib.Path(path) if path is not None else None
        self.live = live
        self.rate_hz = float(rate_hz)
        self.recording_id = recording_id  # None: derived when the episode starts
        self.rec: rr.RecordingStream | None = None
        self._buffer: list[tuple] = []
        self._next_t = 0.0
        self._cycle = 0
        self._closed = False
        self._plan_axes_logged = False
        self._rows: list[str] = []  # the summary's per-dig table, a markdown row per dig
        self._saturated: dict | None = None  # the saturated-servo interval under way: start, joints, peak |F|
        self.sim = self.rig = None

    # -- the observer hooks ---------------------------------------------------------------------
    def started(self, sim, rig, goal_mask: np.ndarray, goal_z: np.ndarray) -> None:
        if self.rec is not None:
            raise UsageError(f"a RerunRecorder records one episode; make a new one for {self.path or self.live}")
        config = self._config_text(sim, rig)
        name = self.path.name if self.path is not None else "live.rrd"
        self.recording_id = self.recording_id or recording_id_for(name, sim.seed, config)
        # no recording properties: they hold the wall-clock start time
        rec = rr.RecordingStream("excavsim", recording_id=self.recording_id, send_properties=False)
        rec.set_log_time_enabled(False)  # reproducible files: only our own timelines
        rec.set_log_tick_enabled(False)
        sinks = []
        if self.path is not None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            sinks.append(rr.FileSink(str(self.path)))
        if self.live:
            sinks.append(rr.GrpcSink(self.live))
        rec.set_sinks(*sinks, default_blueprint=default_blueprint(*trench_camera(rig)))
        rec.send_recording_name(pathlib.Path(name).stem)
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
        rec.log("notes", rr.TextDocument(NOTES, media_type=rr.MediaType.MARKDOWN), static=True)
        g0 = sim.soil.grid
        self._goal_l = 1000 * float(np.clip(self.h0 - goal_z, 0, None)[goal_mask].sum() * g0.cell_area)
        self._title = (f"# Episode: {rig.goal.name or 'inline'} trench, soil {sim.scene.soil}, seed {sim.seed}\n\n")
        self._log_summary("No dig yet: the arm parks, the scanner maps the soil, the planner chooses the first dig.")
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
        strips, colours, names = [], [], []
        points = self.rig.arm.plane_to_world(self.waist, dig.poses[:, :2])
        for p, name in enumerate(PHASE_NAMES):
            idx = np.flatnonzero(dig.phases == p)
            if idx.size:  # each phase's strip starts at the end of the one before, so the path is unbroken
                strips.append(points[max(idx[0] - 1, 0):idx[-1] + 1])
                colours.append(PHASE_RGB[p])
                names.append(name)
        # One label for the whole path (the phases' own labels sat on top of each other, the strips are
        # short): the phases in their colours' order, explained in the notes.
        labels = [f"plan {index}: " + ", ".join(names) if i == len(strips) // 2 else "" for i in range(len(strips))]
        self.rec.log("world/plan/path", rr.LineStrips3D(strips, colors=colours, labels=labels, radii=0.008,
                                                         show_labels=True))
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
        force, tau = d.sensordata[fa:fa + 3].copy(), d.actuator_force[self._act].copy()
        self._buffer.append((t, self._cycle, d.xpos[self._moving].copy(), d.xquat[self._moving].copy(),
                             force, d.sensordata[ta:ta + 3].copy(), tau, d.qpos[self._qadr].copy(),
                             float(np.linalg.norm(contact.force)) if contact is not None else 0.0))
        self._watch_saturation(t, tau, float(np.linalg.norm(force)))
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
        self._rows.append(f"| {index} | {metrics.kind} | {record.outcome} | {values['predicted_l']:.1f} | "
                          f"{values['bucket_l']:.1f} | {metrics.efficiency:.2f} | {values['removed_l']:.1f} | "
                          f"{metrics.stall_joint or '-'} |")
        share = 100 * values["removed_l"] / max(self._goal_l, 1e-9)
        self._log_summary(f"After dig {index}, {self.sim.time:.0f} s simulated: {values['removed_l']:.1f} l of the "
                          f"goal's {self._goal_l:.1f} l removed ({share:.0f} %).")
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
            self._end_saturation()
            self._time(self.sim.time)
            if result is None:
                self._log_summary("**The episode ended with an error**; the log shows how far it got.")
                self._say("the episode ended with an error", level=rr.TextLogLevel.ERROR)
            else:
                self._log_summary(episode_end_text(result))
                self._say(f"ended: {result.reason}")
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

    def _log_summary(self, text: str) -> None:
        """The summary document at the current time: the title, ``text`` and the per-dig table so far."""
        table = ""
        if self._rows:
            table = ("\n\n| dig | kind | outcome | plan [l] | dug [l] | eff. | removed [l] | stall |\n"
                     "|---:|---|---|---:|---:|---:|---:|---|\n" + "\n".join(self._rows) + "\n\n"
                     "removed: in the goal's footprint since the start (cumulative); eff.: dug / plan.")
        self.rec.log("summary", rr.TextDocument(self._title + text + table, media_type=rr.MediaType.MARKDOWN))

    def _watch_saturation(self, t: float, tau: np.ndarray, force_n: float) -> None:
        """Follow the intervals in which a servo is at its torque limit, and log each when it ends: the
        wrist F/T spikes there are the arm's inertia in a fast move, not soil (the plots clip them)."""
        at_limit = np.abs(tau) >= SATURATED * self.sim.torque_limit
        if at_limit.any():
            if self._saturated is None:
                self._saturated = {"start": t, "joints": set(), "peak": 0.0}
            self._saturated["end"] = t
            self._saturated["joints"].update(n for n, hit in zip(constants.ACTUATORS, at_limit) if hit)
            self._saturated["peak"] = max(self._saturated["peak"], force_n)
        elif self._saturated is not None:
            self._end_saturation()

    def _end_saturation(self) -> None:
        sat, self._saturated = self._saturated, None
        if sat is None:
            return
        joints = ", ".join(n for n in constants.ACTUATORS if n in sat["joints"])
        self.rec.set_time("sim_time", duration=float(sat["end"]))
        self._say(f"servos at their torque limit {sat['start']:.1f}-{sat['end']:.1f} s ({joints}): the wrist "
                  f"|F| peaked at {sat['peak'] / 1000:.1f} kN, the arm's inertia in a fast move, not soil "
                  "(the force plots are clipped)", level=rr.TextLogLevel.WARN)

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
        """Every series' name (with its unit) and colour, static."""
        for i, axis in enumerate("xyz"):
            self.rec.log(f"ft/force/{axis}", rr.SeriesLines(names=f"F{axis} [N]", colors=XYZ_RGB[i]), static=True)
            self.rec.log(f"ft/torque/{axis}", rr.SeriesLines(names=f"M{axis} [N m]", colors=XYZ_RGB[i]),
                         static=True)
            self.rec.log(f"ft/tip/{axis}", rr.SeriesPoints(names=f"sensed tip F{axis} [N]", colors=XYZ_RGB[i],
                                                           marker_sizes=1.5), static=True)
        self.rec.log("ft/force/norm", rr.SeriesLines(names="|F| [N]", colors=(200, 200, 200)), static=True)
        self.rec.log("truth/soil_force_n", rr.SeriesLines(names="true soil |F| on bucket [N]", colors=(250, 250, 250),
                                                          widths=2.0), static=True)
        for name, colour in zip(constants.ACTUATORS, ACTUATOR_RGB):
            self.rec.log(f"torque/{name}", rr.SeriesLines(names=f"{name} [N m]", colors=colour), static=True)
            self.rec.log(f"joint_deg/{name}", rr.SeriesLines(names=f"{name} [deg]", colors=colour), static=True)
        for name, (label, colour) in METRIC_SERIES.items():
            self.rec.log(name, rr.SeriesLines(names=label, colors=colour), rr.SeriesPoints(names=label, colors=colour),
                         static=True)

    def _log_goal(self, sim, rig, goal_mask: np.ndarray, goal_z: np.ndarray) -> None:
        goal, arm = rig.goal, rig.arm
        x = np.linspace(goal.near_x_m - 0.2, goal.far_x_m + 0.2, 100)
        centre = arm.plane_to_world(self.waist, np.stack([x, goal_profile(goal, x)], axis=-1))
        along = centre[-1, :2] - centre[0, :2]
        across = np.r_[-along[1], along[0], 0.0] / np.linalg.norm(along) * rig.width / 2
        strips = [centre - across, centre, centre + across]
        self.rec.log("world/goal", rr.LineStrips3D(strips, colors=[(60, 200, 90)] * 3, radii=[0.004, 0.006, 0.004]),
                     static=True)
        # the goal's name at the far end of its centre line, clear of the plan's label in the middle
        self.rec.log("world/goal/name", rr.Points3D([centre[-1] + [0.0, 0.0, 0.05]], colors=(60, 200, 90), radii=0.01,
                                                    labels=[f"goal: {goal.name or 'inline'}"], show_labels=True),
                     static=True)
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
