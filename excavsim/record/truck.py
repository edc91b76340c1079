"""Rerun recording of a self-tuned truck-loading run (``excavsim tune --record FILE.rrd``).

Rowe 1997 §4.3, §6.2. An observer of :func:`excavsim.tasks.truck.tuning.tune` (the loop never
imports it): ``started(cfg, base)``, ``trial(trial, cfg, cost=, sq_error=)`` after every trial (with its
:class:`~excavsim.tasks.truck.trial.TrialTrace` and the loop's cost and squared placement error),
``finished(trials, cfg)``. Everything shown is the mind's
(sensed joints, the robot's own kinematics, scanned maps, the measured pile) except
``world/pile/true``, the true pile's peak from the world's heights, for comparison.

Timelines: ``trial`` (sequence, 1-based) and ``sim_time`` (duration): every trial starts from a fresh
world (§6.2), so the recording lays the trials' scripts end to end, each starting
:data:`TRIAL_GAP_S` after the previous one ended. Entity tree::

    world                    ViewCoordinates (right-handed, z up), static
      target                 Points3D: the dump target (r_d, theta_d) on the soil, per trial
      truck                  LineStrips3D: the truck's side the parameters are computed for (Fig. 3; the
                             truck itself is moved away as in §6.2), per trial
      swing_axis             Points3D: the origin of the polar frame (Fig. 11), static
      soil/scan              Mesh3D: the elevation map after the dump settled, per trial
      pile/measured          Points3D: the pile's position the mind measured (Fig. 11), per trial
      pile/true              Points3D: the true pile's peak (privileged), per trial
      exec/path              LineStrips3D: the bucket tip's path during the script, per trial
      exec/tip               Points3D: the tip at each control tick, on sim_time
    joint_deg/<joint>        the joint angles [deg] on sim_time
    script/<sub-script>      the step index (1-based) of each sub-script, swing, boom, stick, bucket and
                             wrist (the script's phases: a staircase per trial) on sim_time
    metrics/{cost,time_s,sq_error_m2,predicted_cost}   per trial (Fig. 12's learning curve)
    log                      TextLog: every step change, every trial's outcome
    config                   TextDocument: the truck configuration and the computed parameters, static
    summary                  TextDocument: first vs last trials, at the end of the run
"""

from __future__ import annotations

import dataclasses
import math
import os
import pathlib

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from excavsim.errors import ConfigError, UsageError
from excavsim.record.geometry import MAP_RGB, grid_normals, grid_triangles
from excavsim.record.recorder import recording_id_for

TRIAL_GAP_S = 1.0  # the pause between two trials' scripts on the recording's sim_time [s]
JOINT_ENTITY = {"waist_joint": "swing", "shoulder_joint": "boom", "elbow_joint": "stick",
                "wrist_pitch_joint": "bucket", "wrist_yaw_joint": "wrist_yaw", "wrist_roll_joint": "wrist_roll"}
#: The sub-scripts by their first joint (the wrist keeps yaw and roll level in one sub-script).
SUBSCRIPT_ENTITY = {"waist_joint": "swing", "shoulder_joint": "boom", "elbow_joint": "stick",
                    "wrist_pitch_joint": "bucket", "wrist_yaw_joint": "wrist"}
TARGET_RGB = (235, 80, 70)
TRUCK_RGB = (240, 200, 40)
MEASURED_RGB = (90, 200, 90)
TRUE_RGB = (240, 240, 240)
PATH_RGB = (80, 140, 250)


def truck_blueprint() -> rrb.Blueprint:
    """The layout a truck-loading recording opens with: the world, the learning curve, the phases."""
    whole = rrb.TimeRange(start=rrb.TimeRangeBoundary.infinite(), end=rrb.TimeRangeBoundary.infinite())

    def series(name: str, path: str, timeline: str) -> rrb.TimeSeriesView:
        return rrb.TimeSeriesView(name=name, origin="/", contents=[f"+ {path}"],
                                  axis_x=rrb.TimeAxis(view_range=whole) if timeline == "trial" else None,
                                  plot_legend=rrb.PlotLegend(rrb.Corner2D.RightTop, visible=True))

    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Vertical(rrb.Spatial3DView(name="dump site (scanned map, pile, target)", origin="/world"),
                         rrb.Tabs(rrb.TextDocumentView(name="summary", origin="/summary"),
                                  rrb.TextLogView(name="log", origin="/log"),
                                  rrb.TextDocumentView(name="config", origin="/config")),
                         row_shares=[3, 2]),
            rrb.Vertical(rrb.Tabs(series("cost (Fig. 12)", "/metrics/cost", "trial"),
                                  series("time [s]", "/metrics/time_s", "trial"),
                                  series("squared error [m^2]", "/metrics/sq_error_m2", "trial"),
                                  series("predicted cost", "/metrics/predicted_cost", "trial")),
                         series("script phases (step of each sub-script)", "/script/**", "sim_time"),
                         series("joint angles [deg]", "/joint_deg/**", "sim_time")),
            column_shares=[3, 2]),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(timeline="trial", state="collapsed"),
    )


def _polar(r: float, theta: float, z: float) -> list[float]:
    return [r * math.cos(theta), r * math.sin(theta), z]


class TruckRecorder:
    """Records one :func:`~excavsim.tasks.truck.tuning.tune` run to ``path`` (see the module docstring).

    Args:
        path: the ``.rrd`` file to write.
        seed: the run's seed (part of the recording id, so that a run recorded again gets the same id).
    """

    def __init__(self, path: str | os.PathLike, *, seed: int = 0):
        self.path = pathlib.Path(path)
        if self.path.suffix != ".rrd":
            raise ConfigError(f"a truck recording must be an .rrd file; given {str(path)!r}")
        self.seed = int(seed)
        self.rec: rr.RecordingStream | None = None
        self._offset = 0.0
        self._target: tuple[float, float] | None = None
        self._metrics: list[tuple[int, float, float, float, float]] = []

    def started(self, cfg, base) -> None:
        if self.rec is not None:
            raise UsageError(f"a TruckRecorder records one run; make a new one for {self.path}")
        text = self._config_text(cfg, base)
        rec = rr.RecordingStream("excavsim", recording_id=recording_id_for(self.path.name, self.seed, text),
                                 send_properties=False)
        rec.set_log_time_enabled(False)
        rec.set_log_tick_enabled(False)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        rec.save(str(self.path), default_blueprint=truck_blueprint())
        self.rec = rec
        rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        rec.log("world/swing_axis", rr.Points3D([[0.0, 0.0, 0.0]], radii=0.03, labels=["swing axis (Fig. 11)"]),
                static=True)
        rec.log("config", rr.TextDocument(text, media_type=rr.MediaType.MARKDOWN), static=True)

    @staticmethod
    def _config_text(cfg, base) -> str:
        lines = ["# Truck loading, self-tuned (Rowe 1997 §6.2)", "", "## Configuration", ""]
        for f in dataclasses.fields(cfg):
            v = getattr(cfg, f.name)
            if isinstance(v, np.ndarray):
                v = np.round(v, 4).tolist()
            lines.append(f"* `{f.name}`: {v}")
        lines += ["", "## The computed parameters (§4.2), angles in degrees", ""]
        lines += [f"* `{k}`: {v:.4g}" for k, v in base.degrees().items()]
        return "\n".join(lines)

    def trial(self, trial, cfg, *, cost: float, sq_error: float) -> None:
        if self.rec is None:
            raise UsageError("TruckRecorder.trial before started")
        if trial.trace is None:
            raise UsageError(f"trial {trial.index + 1} carries no trace: run it with trace=True to record it")
        rec, tr, k = self.rec, trial.trace, trial.index + 1
        t0 = self._offset
        rec.set_time("trial", sequence=k)
        rec.set_time("sim_time", duration=t0)
        target = (trial.r_d, trial.theta_d) if not math.isnan(trial.r_d) else (cfg.site.r_d, cfg.site.theta_d)
        if target != self._target:
            self._log_site(cfg, target)
            self._target = target
        # the phases: one staircase per sub-script, and a log line per step change
        tcol = rr.TimeColumn("sim_time", duration=t0 + tr.times)
        for j, name in enumerate(("waist_joint", "shoulder_joint", "elbow_joint", "wrist_pitch_joint",
                                  "wrist_yaw_joint", "wrist_roll_joint")):
            rec.send_columns(f"joint_deg/{JOINT_ENTITY[name]}", indexes=[tcol],
                             columns=rr.Scalars.columns(scalars=np.degrees(tr.q[:, j])))
        rec.send_columns("world/exec/tip", indexes=[tcol],
                         columns=[*rr.Points3D.columns(positions=tr.tip.astype(np.float32)),
                                  *rr.Points3D.columns(radii=np.full(len(tr.tip), 0.03, np.float32))])
        steps: dict[str, list[tuple[float, int]]] = {}
        for t, joint, step in tr.phases:
            steps.setdefault(joint, []).append((t, len(steps.get(joint, [])) + 1))
            rec.set_time("sim_time", duration=t0 + t)
            rec.log("log", rr.TextLog(f"trial {k} +{t:5.2f} s  {SUBSCRIPT_ENTITY.get(joint, joint)}: {step}"))
        for joint, seq in steps.items():
            # hold each step until the next one (and the last one to the script's end) on the staircase
            times = [t for t, _ in seq] + [trial.time_s]
            idx = [i for _, i in seq] + [seq[-1][1]]
            rec.send_columns(f"script/{SUBSCRIPT_ENTITY.get(joint, joint)}",
                             indexes=[rr.TimeColumn("sim_time", duration=t0 + np.asarray(times))],
                             columns=rr.Scalars.columns(scalars=np.asarray(idx, dtype=float)))
        # the outcome, at the script's end
        rec.set_time("sim_time", duration=t0 + trial.time_s)
        rec.log("world/exec/path", rr.LineStrips3D([tr.tip.astype(np.float32)], colors=[PATH_RGB], radii=0.01,
                                                   labels=[f"trial {k}"]))
        self._log_map(tr.after)
        p, q = trial.pile, trial.true
        rec.log("world/pile/measured", rr.Points3D([[p.x, p.y, p.z]], colors=[MEASURED_RGB], radii=0.04,
                                                   labels=[f"measured r {p.r:.3f} m, theta "
                                                           f"{math.degrees(p.theta):.1f} deg"]))
        rec.log("world/pile/true", rr.Points3D([[q.x, q.y, q.z]], colors=[TRUE_RGB], radii=0.025,
                                               labels=["true peak"]))
        err2 = sq_error
        self._metrics.append((k, cost, trial.time_s, err2, trial.predicted_cost))
        for name, v in (("cost", cost), ("time_s", trial.time_s), ("sq_error_m2", err2),
                        ("predicted_cost", trial.predicted_cost)):
            if np.isfinite(v):
                rec.log(f"metrics/{name}", rr.Scalars(float(v)))
        rec.log("log", rr.TextLog(f"trial {k} ({trial.source}): {trial.outcome}, time {trial.time_s:.2f} s, pile r "
                                  f"{p.r:.3f} m theta {math.degrees(p.theta):.1f} deg, cost {cost:.2f}"
                                  + (" FAILED" if trial.failed else ""),
                                  level=rr.TextLogLevel.WARN if trial.failed else rr.TextLogLevel.INFO))
        self._offset = t0 + trial.time_s + TRIAL_GAP_S

    def _log_site(self, cfg, target: tuple[float, float]) -> None:
        rec, site = self.rec, cfg.site
        r_d, th = target
        z = float(site.side_z)
        rec.log("world/target", rr.Points3D([_polar(r_d, th, z - 0.3)], colors=[TARGET_RGB], radii=0.05,
                                            labels=[f"target r {r_d:.2f} m, theta {math.degrees(th):.0f} deg"]))
        # the truck's side as a square bed of the configured half-width about the target (display only)
        w = float(site.half_width)
        radial, tangent = np.array([math.cos(th), math.sin(th), 0.0]), np.array([-math.sin(th), math.cos(th), 0.0])
        c = np.array(_polar(r_d, th, z))
        corners = [c + a * w * radial + b * w * tangent for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1), (-1, -1))]
        rec.log("world/truck", rr.LineStrips3D([np.array(corners, np.float32)], colors=[TRUCK_RGB], radii=0.01,
                                               labels=["truck side (moved away, §6.2)"]))

    def _log_map(self, emap) -> None:
        ny, nx = emap.shape
        xc, yc = emap.centres()
        xs, ys = np.meshgrid(xc, yc)
        verts = np.stack([xs, ys, emap.heights], axis=-1).reshape(-1, 3).astype(np.float32)
        self.rec.log("world/soil/scan", rr.Mesh3D(vertex_positions=verts, triangle_indices=grid_triangles(ny, nx),
                                                  vertex_normals=grid_normals(emap.heights, emap.cell),
                                                  vertex_colors=np.tile(MAP_RGB.astype(np.uint8), (ny * nx, 1))))

    def finished(self, trials, cfg) -> None:
        if self.rec is None:
            return
        m = np.array([r[:4] for r in self._metrics]) if self._metrics else np.zeros((0, 4))
        n = min(cfg.initial_trials, len(m))
        lines = ["# Learning curve (Fig. 12)", "", "| trials | cost | time [s] | squared error [m^2] |",
                 "| --- | --- | --- | --- |"]
        if n:
            for label, part in ((f"first {n}", m[:n]), (f"last {n}", m[-n:])):
                lines.append(f"| {label} | {part[:, 1].mean():.2f} | {part[:, 2].mean():.2f} | "
                             f"{part[:, 3].mean():.5f} |")
        lines += ["", f"{len(m)} trials, {sum(t.failed for t in trials)} failed."]
        self.rec.log("summary", rr.TextDocument("\n".join(lines), media_type=rr.MediaType.MARKDOWN))
        self.rec.flush()
        self.rec.disconnect()
