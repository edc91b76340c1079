"""Rerun recordings of trenching episodes, on any trenching machine (the T3, the TB035, the 25 t excavator).

:class:`TrenchRecorder` is the trenching task's :class:`~excavsim.record.base.EpisodeRecorder`
(``started(sim, rig, goal_mask, goal_z)``, the trench task's ``reset``): it adds the trench's entities to
what the base records. It stays in :mod:`excavsim.record` (not in the task's folder) because the
applications record the T3 with it too (its teleoperation, the calibration's digs) and read its
recordings back (:mod:`excavsim.record.reading`, :mod:`excavsim.record.demo_reading`).

Timelines: ``sim_time`` (duration, simulated seconds) and ``dig`` (sequence: the cycle index, 0
before the first scan; cycle k scans, plans and digs dig k); the samples carry ``step`` too. Entity
tree (``<machine>``: ``t3``, ``tb035``, ``excavator_25t``; ``<joint>``: the machine's joints without
``_joint``)::

    world                      ViewCoordinates (right-handed, z up), static
      <machine>/<body>         Transform3D of each moving body (xpos/xquat) at rate_hz
      <machine>/<body>/<geom>  visual geoms in the body frame (Mesh3D, Boxes3D, Cylinders3D, ...), static
      box/<geom>               the soil box's walls (the pit's ground), scanner mast and survey targets, static
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
    torque/<joint>             joint torques [N m] (the T3's actuators; an excavator's cylinders through
                               their moment arms), rate_hz
    joint_deg/<joint>          joint angles [deg], rate_hz
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

A default blueprint (:func:`~excavsim.record.blueprint.default_blueprint`) goes with the file: 3D views
of the world with the true terrain and with the map (the camera on the trench, :func:`trench_camera`),
the feasible set, time series of the signals (the T3's force plots on fixed ranges that show digging)
and metrics, the summary. What recording costs (wall time, file size per dig) is measured in the
README's recording section.
"""

from __future__ import annotations

import os

import numpy as np
import yaml

from excavsim import constants
from excavsim.handoff.episode import DigMetrics, EpisodeResult
from excavsim.handoff.goal import goal_profile
from excavsim.record.blueprint import default_blueprint
from excavsim.record.drawing import ERROR, INFO, WARN, Times
from excavsim.record.geometry import (FILLED_RGB, MAP_RGB, OVERDIG_RGB, PHASE_NAMES, PHASE_RGB, PLAN_AXIS_LENGTH,
                                      SAND_RGB, ramp_colours)
from excavsim.record.base import Batch, EpisodeRecorder

SATURATED = 0.999  # a servo whose |torque| is at least this fraction of its limit is saturated
XYZ_RGB = ((235, 80, 70), (90, 200, 90), (80, 140, 250))
ACTUATOR_RGB = ((31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40), (148, 103, 189), (227, 119, 194))
GOAL_RGB = (60, 200, 90)
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
T3_TRENCH_M = 1.2  # the T3's longest trench goal: the camera's distances are for it, and scale beyond
SHADE_DEPTH_M = 0.3  # the terrain is shaded darker with depth down to this (or the goal's depth, if more)
NOTES = """# How to read this recording

* **Timelines**: `sim_time` (simulated seconds) and `dig` (the cycle: scan, plan and dig k).
* **Forces**: *forces while digging* shows what the executor sensed at the bucket tip (points, only
  during digs) and the true soil force on the bucket (white line). The wrist F/T plots hold the
  sensor's reading in its own frame, bucket weight included (~275 N at rest on the T3). On the T3 all
  force plots have fixed ranges (-1 to 1.5 kN, +-1.5 kN, +-1 kN m): while a servo is at its torque
  limit (the park move at the start, fast moves between digs) the wrist reads up to ~14 kN of the
  arm's own inertia; those spikes are clipped, and the log names each such interval and its peak.
  Scroll or double-click a plot to see its whole range.
* **Planned path**: penetrate (orange), drag (yellow), curl (blue); the measured path is white.
* **Terrain**: sand coloured darker with depth, red where the goal is over-dug; the scanned map is
  blue, orange where cells were filled, not observed.
* **Soil [l]**: planned and dug are per dig; *removed so far* is cumulative (the goal's footprint).
* **Summary**: grows after every dig; the episode's end is added when it ends.
"""


def trench_camera(rig) -> tuple[np.ndarray, np.ndarray]:
    """Where the 3-D views' camera starts and what it looks at: the middle of the trench, seen from
    the side of the arm plane and above, so that the trench, the bucket and the spoil fill the view
    (further away for a trench longer than the T3's)."""
    goal, arm = rig.goal, rig.arm
    waist = float(np.radians(goal.waist_deg))
    near, mid, far = arm.plane_to_world(waist, np.array([[goal.near_x_m, goal.surface_z_m],
                                                          [(goal.near_x_m + goal.far_x_m) / 2, goal.surface_z_m],
                                                          [goal.far_x_m, goal.surface_z_m]]))
    along = (far - near) / max(np.linalg.norm(far - near), 1e-9)
    across = np.array([-along[1], along[0], 0.0])
    scale = max(1.0, (goal.far_x_m - goal.near_x_m) / T3_TRENCH_M)
    # beside the arm plane, behind the trench's middle towards the robot, and above [m]
    eye = mid + scale * (-2.6 * across - 0.9 * along + np.array([0.0, 0.0, 1.9]))
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


class TrenchRecorder(EpisodeRecorder):
    """Records one trenching episode to ``path`` (an ``.rrd`` file; see the module docstring).

    Args:
        path, rate_hz, recording_id, live: see :class:`~excavsim.record.base.EpisodeRecorder`.

    Raises:
        ExcavsimError: as the base's.
    """

    sample_timelines = ("dig",)

    def __init__(self, path: str | os.PathLike | None, *, rate_hz: float = 10.0, recording_id: str | None = None,
                 live: str | None = None):
        super().__init__(path, rate_hz=rate_hz, recording_id=recording_id, live=live)
        self._plan_axes_logged = False
        self._rows: list[str] = []  # the summary's per-dig table, a markdown row per dig
        self._saturated: dict | None = None  # the saturated-servo interval under way: start, joints, peak |F|
        self.sim = self.rig = None

    # -- the base's hooks ---------------------------------------------------------------------------
    def begin(self, sim, rig, goal_mask: np.ndarray, goal_z: np.ndarray):
        self.sim, self.rig = sim, rig
        self.goal_mask, self.goal_z, self.h0 = goal_mask, goal_z, sim.soil.grid.heights.copy()
        self.waist = float(np.radians(rig.goal.waist_deg))
        m = sim.model
        self._names = [j.removesuffix("_joint") for j in rig.machine.joints]
        self._qadr = np.array([m.joint(j).qposadr[0] for j in rig.machine.joints])
        self._ft_adr = [int(m.sensor(s).adr[0]) for s in (constants.FT_FORCE_SENSOR, constants.FT_TORQUE_SENSOR)]
        # the joints' torques: an excavator's world has them (its cylinders through their moment arms), the
        # T3's are its actuators' forces
        act = np.array([m.actuator(n).id for n in self._names]) if not hasattr(sim, "joint_torques") else None
        self._torques = sim.joint_torques if act is None else (lambda: sim.data.actuator_force[act].copy())
        return sim

    def config_text(self) -> str:
        sim, rig = self.sim, self.rig
        parts = {"goal": rig.goal, "robot": getattr(sim, "robot", None), "scene": sim.scene,
                 "planner": rig.planner_cfg, "executor": rig.executor_cfg, "sensing": rig.sensing_cfg}
        dumped = {"machine": rig.machine.name,
                  **{name: cfg.model_dump(mode="json") for name, cfg in parts.items() if cfg is not None}}
        return f"# Resolved configuration\n\n```yaml\n{yaml.safe_dump(dumped, sort_keys=False)}```\n"

    def blueprint(self):
        return default_blueprint(*trench_camera(self.rig), fixed_ranges=self.rig.machine.hydraulics is None)

    def setup(self) -> None:
        sim, rig = self.sim, self.rig
        self._now()
        self.frame("plan")
        self.document("notes", NOTES, static=True)
        g0 = sim.soil.grid
        self._goal_l = 1000 * float(np.clip(self.h0 - self.goal_z, 0, None)[self.goal_mask].sum() * g0.cell_area)
        depth = (rig.goal.surface_z_m - self.goal_z)[self.goal_mask]
        self._shade_m = max(SHADE_DEPTH_M, float(depth.max()) if depth.size else 0.0)
        by = "" if rig.machine.name == "t3" else f" with the {rig.machine.name}"
        self._title = f"# Episode: {rig.goal.name or 'inline'} trench{by}, soil {sim.scene.soil}, seed {sim.seed}\n\n"
        self._log_summary("No dig yet: the arm parks, the scanner maps the soil, the planner chooses the first dig.")
        self.draw_bodies(sim, rig.machine.name, {constants.SOIL_BOX_BODY: "world/box"})
        self._log_series_styles()
        self._log_goal()
        self._log_true_terrain()
        self.say(f"episode: goal {rig.goal.name or '(inline)'} at waist {rig.goal.waist_deg:g} deg, "
                 f"soil {sim.scene.soil}, recorded at {self.rate_hz:g} Hz")

    def sample(self, sim) -> dict:
        d = sim.data
        fa, ta = self._ft_adr
        force, tau = d.sensordata[fa:fa + 3].copy(), self._torques()
        contact = sim.contact
        self._watch_saturation(float(sim.time), tau, float(np.linalg.norm(force)))
        return {"force": force, "torque": d.sensordata[ta:ta + 3], "tau": tau, "q": d.qpos[self._qadr],
                "soil": float(np.linalg.norm(contact.force)) if contact is not None else 0.0}

    def send(self, batch: Batch) -> None:
        at, force, torque, tau, q = batch.at, batch["force"], batch["torque"], batch["tau"], batch["q"]
        for i, axis in enumerate("xyz"):
            self.scalar_columns(f"ft/force/{axis}", force[:, i], at)
            self.scalar_columns(f"ft/torque/{axis}", torque[:, i], at)
        self.scalar_columns("ft/force/norm", np.linalg.norm(force, axis=1), at)
        for j, name in enumerate(self._names):
            self.scalar_columns(f"torque/{name}", tau[:, j], at)
            self.scalar_columns(f"joint_deg/{name}", np.degrees(q[:, j]), at)
        self.scalar_columns("truth/soil_force_n", batch["soil"], at)

    def ended(self, result: EpisodeResult | None) -> None:
        self._end_saturation()
        self._now()
        if result is None:
            self._log_summary("**The episode ended with an error**; the log shows how far it got.")
            self.say("the episode ended with an error", ERROR)
        else:
            self._log_summary(episode_end_text(result))
            self.say(f"ended: {result.reason}")

    # -- the episode's hooks ------------------------------------------------------------------------
    def scanned(self, index: int, emap, accuracy) -> None:
        self.flush()
        self.sequence["dig"] = index
        self._now()
        self.height_map("world/soil/scan", emap,
                        colours=np.where(emap.observed.reshape(-1, 1), MAP_RGB, FILLED_RGB))
        self.scalar("metrics/map_rms_cm", 100 * accuracy.rms_m)
        self.say(f"scan {index}: {accuracy.summary()}")

    def planned(self, index: int, plan, dig) -> None:
        self.flush()
        self._now()
        if plan is not None:
            self._log_feasible(plan)
        self.clear("world/exec/path")  # the last dig's path, until this one's
        if dig is None:
            self.clear("world/plan/path")
            why = f" ({plan.reason}) and no fallback" if plan is not None else ""
            self.say(f"plan {index}: no dig{why}", WARN)
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
        self.lines("world/plan/path", strips, colours=colours, labels=labels, radii=0.008, show_labels=True)
        if dig.action is None:
            why = f"{plan.reason}; " if plan is not None else ""
            self.say(f"plan {index}: {why}{dig.kind}, {1000 * dig.volume_m3:.1f} l")
        else:
            k, a, d1, d2 = dig.action
            how = f"{plan.reason}, " if plan is not None and dig.kind == "planned" else f"{dig.kind}, "
            self.say(f"plan {index}: k {k:.2f} m, alpha {np.degrees(a):.0f} deg, d1 {d1:.2f} m, d2 {d2:.2f} m, "
                     f"{1000 * dig.volume_m3:.1f} l ({how.removesuffix(', ')})")

    def dug(self, index: int, record, metrics: DigMetrics) -> None:
        self.flush()
        self._now()
        if record.executed_path:
            path = np.asarray(record.executed_path)
            self.lines("world/exec/path", [self.rig.arm.plane_to_world(self.waist, path[:, :2])],
                       colours=(240, 240, 240), radii=0.008)
        if record.ft:
            at = Times(np.array([r[0] for r in record.ft]))
            f = np.array([r[1] for r in record.ft])
            for i, axis in enumerate("xyz"):
                self.scalar_columns(f"ft/tip/{axis}", f[:, i], at)
        self._log_true_terrain()
        cell = self.sim.soil.grid.cell_area
        removed = float(np.clip(self.h0 - self.sim.soil.grid.heights, 0, None)[self.goal_mask].sum() * cell)
        values = {"predicted_l": 1000 * metrics.predicted_m3, "bucket_l": 1000 * metrics.bucket_m3,
                  "efficiency": metrics.efficiency, "sim_s": metrics.sim_s,
                  "removed_l": 1000 * removed, "stall": float(metrics.stall_joint is not None)}
        for name, value in values.items():
            self.scalar(f"metrics/{name}", value)
        self.scalar("wall/planning_s", metrics.planning_s)
        self._rows.append(f"| {index} | {metrics.kind} | {record.outcome} | {values['predicted_l']:.1f} | "
                          f"{values['bucket_l']:.1f} | {metrics.efficiency:.2f} | {values['removed_l']:.1f} | "
                          f"{metrics.stall_joint or '-'} |")
        share = 100 * values["removed_l"] / max(self._goal_l, 1e-9)
        self._log_summary(f"After dig {index}, {self.sim.time:.0f} s simulated: {values['removed_l']:.1f} l of the "
                          f"goal's {self._goal_l:.1f} l removed ({share:.0f} %).")
        warn = metrics.stall_joint is not None or not record.completed
        self.say(f"dig {index} ({metrics.kind}): {record.outcome}, {1000 * metrics.predicted_m3:.1f} l planned, "
                 f"{1000 * metrics.bucket_m3:.1f} l dug, touch-down offset {100 * record.touch_offset_m:.1f} cm"
                 + (f", stall at {metrics.stall_joint}" if metrics.stall_joint else "")
                 + "".join(f"; {w}" for w in record.warnings), WARN if warn else INFO)

    # -- helpers --------------------------------------------------------------------------------------
    def _now(self) -> None:
        """Log what follows at the world's time and the cycle."""
        self.at(self.sim.time, dig=self.sequence["dig"])

    def _log_summary(self, text: str) -> None:
        """The summary document at the current time: the title, ``text`` and the per-dig table so far."""
        table = ""
        if self._rows:
            table = ("\n\n| dig | kind | outcome | plan [l] | dug [l] | eff. | removed [l] | stall |\n"
                     "|---:|---|---|---:|---:|---:|---:|---|\n" + "\n".join(self._rows) + "\n\n"
                     "removed: in the goal's footprint since the start (cumulative); eff.: dug / plan.")
        self.document("summary", self._title + text + table)

    def _watch_saturation(self, t: float, tau: np.ndarray, force_n: float) -> None:
        """Follow the intervals in which a servo is at its torque limit, and log each when it ends: the
        wrist F/T spikes there are the arm's inertia in a fast move, not soil (the plots clip them)."""
        at_limit = np.abs(tau) >= SATURATED * np.abs(self.sim.torque_limit)
        if at_limit.any():
            if self._saturated is None:
                self._saturated = {"start": t, "joints": set(), "peak": 0.0}
            self._saturated["end"] = t
            self._saturated["joints"].update(n for n, hit in zip(self._names, at_limit) if hit)
            self._saturated["peak"] = max(self._saturated["peak"], force_n)
        elif self._saturated is not None:
            self._end_saturation()

    def _end_saturation(self) -> None:
        sat, self._saturated = self._saturated, None
        if sat is None:
            return
        joints = ", ".join(n for n in self._names if n in sat["joints"])
        self.at(sat["end"], dig=self.sequence["dig"])
        self.say(f"servos at their torque limit {sat['start']:.1f}-{sat['end']:.1f} s ({joints}): the wrist "
                 f"|F| peaked at {sat['peak'] / 1000:.1f} kN, the arm's inertia in a fast move, not soil "
                 "(the force plots are clipped)", WARN)

    def _log_series_styles(self) -> None:
        """Every series' name (with its unit) and colour, static."""
        for i, axis in enumerate("xyz"):
            self.series_style(f"ft/force/{axis}", f"F{axis} [N]", XYZ_RGB[i])
            self.series_style(f"ft/torque/{axis}", f"M{axis} [N m]", XYZ_RGB[i])
            self.series_style(f"ft/tip/{axis}", f"sensed tip F{axis} [N]", XYZ_RGB[i], lines=False, points=True,
                              marker_size=1.5)
        self.series_style("ft/force/norm", "|F| [N]", (200, 200, 200))
        self.series_style("truth/soil_force_n", "true soil |F| on bucket [N]", (250, 250, 250), width=2.0)
        for name, colour in zip(self._names, ACTUATOR_RGB):
            self.series_style(f"torque/{name}", f"{name} [N m]", colour)
            self.series_style(f"joint_deg/{name}", f"{name} [deg]", colour)
        for name, (label, colour) in METRIC_SERIES.items():
            self.series_style(name, label, colour, points=True)

    def _log_goal(self) -> None:
        sim, rig = self.sim, self.rig
        goal, arm = rig.goal, rig.arm
        x = np.linspace(goal.near_x_m - 0.2, goal.far_x_m + 0.2, 100)
        centre = arm.plane_to_world(self.waist, np.stack([x, goal_profile(goal, x)], axis=-1))
        along = centre[-1, :2] - centre[0, :2]
        across = np.r_[-along[1], along[0], 0.0] / np.linalg.norm(along) * rig.width / 2
        self.lines("world/goal", [centre - across, centre, centre + across], colours=[GOAL_RGB] * 3,
                   radii=[0.004, 0.006, 0.004], static=True)
        # the goal's name at the far end of its centre line, clear of the plan's label in the middle
        self.points("world/goal/name", [centre[-1] + [0.0, 0.0, 0.05]], colours=GOAL_RGB, radii=0.01,
                    labels=[f"goal: {goal.name or 'inline'}"], show_labels=True, static=True)
        g = sim.soil.grid
        rows, cols = np.nonzero(self.goal_mask)
        gx, gy = g.xy(rows, cols)
        # The goal profile is a world height, as the map's (the box floor is at z0 = 0 in the scene).
        self.points("world/goal/footprint", np.stack([gx, gy, self.goal_z[rows, cols]], axis=-1), colours=GOAL_RGB,
                    radii=0.006, static=True)

    def _log_true_terrain(self) -> None:
        h = self.sim.soil.grid.heights
        depth = np.clip(self.rig.goal.surface_z_m - h, 0, 1).reshape(-1, 1)
        colours = SAND_RGB * (1 - 0.8 * np.minimum(depth / self._shade_m, 1))  # darker with depth below the surface
        over = (self.goal_mask & (h < self.goal_z - 0.01)).reshape(-1)
        colours[over] = OVERDIG_RGB
        self.heightfield("world/soil/truth", self.sim.soil.grid, colours=colours)

    def _log_feasible(self, plan) -> None:
        axes = (np.asarray(plan.grid_k), np.degrees(plan.grid_alpha), np.asarray(plan.grid_d1))
        lows = np.array([a.min() for a in axes])
        steps = np.array([np.min(np.diff(a)) if a.size > 1 else 1.0 for a in axes])
        scale = PLAN_AXIS_LENGTH / np.maximum(np.array([a.max() for a in axes]) - lows, steps)
        if not self._plan_axes_logged:
            self._plan_axes_logged = True
            ends = np.array([[0, 0, 0], [PLAN_AXIS_LENGTH, 0, 0], [0, PLAN_AXIS_LENGTH, 0], [0, 0, PLAN_AXIS_LENGTH]])
            labels = [f"k {lows[0]:.2f} m, alpha {lows[1]:.0f} deg, d1 {lows[2]:.2f} m", f"k {axes[0].max():.2f} m",
                      f"alpha {axes[1].max():.0f} deg", f"d1 {axes[2].max():.2f} m"]
            self.lines("plan/axes", [[ends[0], e] for e in ends[1:]], colours=(200, 200, 200), static=True)
            self.points("plan/axes", ends, labels=labels, radii=0.01, static=True)
        cells = np.argwhere(plan.feasible)
        centres = np.stack([(axes[i][cells[:, i]] - lows[i]) * scale[i] for i in range(3)], axis=-1)
        volume = np.nan_to_num(plan.volume[plan.feasible]) * 1000
        self.boxes("plan/feasible", centres, np.tile(0.42 * steps * scale, (len(cells), 1)),
                   colours=ramp_colours(volume / (self.rig.capacity * 1000)), solid=True,
                   labels=[f"{v:.1f} l" for v in volume], show_labels=False)
        if plan.action is None:
            self.clear("plan/chosen")
            return
        k, a, d1, _ = plan.action
        idx = [int(np.argmin(np.abs(axes[i] - v))) for i, v in enumerate((k, np.degrees(a), d1))]
        centre = [(axes[i][idx[i]] - lows[i]) * scale[i] for i in range(3)]
        self.boxes("plan/chosen", [centre], [0.6 * steps * scale], colours=(255, 40, 40), radii=0.006,
                   labels=[f"chosen: k {k:.2f} m, alpha {np.degrees(a):.0f} deg, d1 {d1:.2f} m, "
                           f"{1000 * plan.volume_m3:.1f} l"])


