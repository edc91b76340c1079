"""The Rerun recordings of truck-loading trials on the T3: a self-tuned run (``excavsim tune --record FILE.rrd``)
and a ``task: dump_trial`` episode (``excavsim run SPEC --record FILE.rrd``).

Rowe 1997 §4.3, §6.2. :class:`TruckRecorder` observes :func:`excavsim.tasks.dump_trial.tuning.tune` (the loop
never imports it): ``started(cfg, base)``, ``trial(trial, cfg, cost=, sq_error=)`` after every trial (with
its :class:`~excavsim.tasks.dump_trial.trial.TrialTrace` and the loop's cost and squared placement error),
``finished(trials, cfg)``. :class:`TrialRecorder` records an episode of the task the same way, from the
episode's hooks (``started(sim, cfg)``, ``dug(index, trial)``, ``finished(result)``): its one trial, or
every trial of a tuning run. Everything shown is the mind's (sensed joints, the robot's own kinematics,
scanned maps, the measured pile) except ``world/pile/true``, the true pile's peak from the world's
heights, for comparison.

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
    config                   TextDocument: the truck configuration, static
    parameters               TextDocument: the computed parameters (§4.2) of a tuning run, or an
                             episode's first trial's, static
    summary                  TextDocument: first vs last trials, at the end of the run
"""

from __future__ import annotations

import dataclasses
import math
import os

import numpy as np

from excavsim.errors import UsageError
from excavsim.record.blueprint import column, document_view, layout, log_view, row, series_view, tabs, world_view
from excavsim.record.drawing import ERROR, INFO, WARN, Times
from excavsim.record.geometry import MAP_RGB
from excavsim.record.base import EpisodeRecorder
from excavsim.tasks.dump_trial.trial import Trial, placement_error2, trial_cost

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


def truck_blueprint():
    """The layout a truck-loading recording opens with: the world, the learning curve, the phases."""
    return layout(row(
        column(world_view("dump site (scanned map, pile, target)"),
               tabs(document_view("summary", "/summary"), log_view(), document_view("config", "/config"),
                    document_view("parameters", "/parameters")),
               shares=[3, 2]),
        column(tabs(series_view("cost (Fig. 12)", "/metrics/cost", whole=True),
                    series_view("time [s]", "/metrics/time_s", whole=True),
                    series_view("squared error [m^2]", "/metrics/sq_error_m2", whole=True),
                    series_view("predicted cost", "/metrics/predicted_cost", whole=True)),
               series_view("script phases (step of each sub-script)", "/script/**"),
               series_view("joint angles [deg]", "/joint_deg/**")),
        shares=[3, 2]), timeline="trial")


def _polar(r: float, theta: float, z: float) -> list[float]:
    return [r * math.cos(theta), r * math.sin(theta), z]


class TruckRecorder(EpisodeRecorder):
    """Records one :func:`~excavsim.tasks.dump_trial.tuning.tune` run to ``path`` (see the module docstring).

    Args:
        path: the ``.rrd`` file to write.
        seed: the run's seed (part of the recording id, so that a run recorded again gets the same id).
        live: also stream the run to the viewer at this gRPC URL.

    Raises:
        ExcavsimError: not an ``.rrd`` path; a trial before :meth:`started` or without a trace.
    """

    def __init__(self, path: str | os.PathLike | None, *, seed: int | None = 0, live: str | None = None):
        super().__init__(path, seed=seed, live=live)
        self.cfg = None
        self._offset = 0.0  # where the next trial starts on sim_time [s]
        self._target: tuple[float, float] | None = None
        self._metrics: list[tuple[int, float, float, float, float]] = []

    # -- the base's hooks ------------------------------------------------------------------------------
    def begin(self, cfg, base=None):
        self.cfg, self._base = cfg, base
        return None

    def config_text(self) -> str:
        lines = ["# Truck loading (Rowe 1997 §6.2)", "", "## Configuration", ""]
        for f in dataclasses.fields(self.cfg):
            v = getattr(self.cfg, f.name)
            if isinstance(v, np.ndarray):
                v = np.round(v, 4).tolist()
            lines.append(f"* `{f.name}`: {v}")
        return "\n".join(lines)

    def blueprint(self):
        return truck_blueprint()

    def setup(self) -> None:
        self.points("world/swing_axis", [[0.0, 0.0, 0.0]], radii=0.03, labels=["swing axis (Fig. 11)"], static=True)
        if self._base is not None:
            self.parameters(self._base, "The computed parameters (§4.2)")

    def stepped(self, world) -> None:
        """Nothing: each trial's trace carries its joints and tip (:meth:`trial`)."""

    def finished(self, trials=None, cfg=None) -> None:
        """The run's end: ``trials`` (None: it ended with an error); ``cfg`` is the one of :meth:`started`."""
        super().finished(trials)

    def ended(self, trials) -> None:
        """The summary: the first and the last trials' means (Fig. 12)."""
        self.at(self._offset, trial=len(self._metrics))
        m = np.array([r[:4] for r in self._metrics]) if self._metrics else np.zeros((0, 4))
        n = min(self.cfg.initial_trials, len(m))
        lines = ["# Learning curve (Fig. 12)", "", "| trials | cost | time [s] | squared error [m^2] |",
                 "| --- | --- | --- | --- |"]
        if n:
            for label, part in ((f"first {n}", m[:n]), (f"last {n}", m[-n:])):
                lines.append(f"| {label} | {part[:, 1].mean():.2f} | {part[:, 2].mean():.2f} | "
                             f"{part[:, 3].mean():.5f} |")
        if trials is None:
            lines += ["", f"{len(m)} trials recorded; **the run ended with an error**."]
            self.say("the run ended with an error", ERROR)
        else:
            lines += ["", f"{len(m)} trials, {sum(t.failed for t in trials)} failed."]
        self.document("summary", "\n".join(lines))

    # -- the run's hooks ---------------------------------------------------------------------------------
    def parameters(self, params, title: str) -> None:
        """The script's parameters (angles in degrees), static, under ``title``."""
        lines = [f"# {title}", ""] + [f"* `{k}`: {v:.4g}" for k, v in params.degrees().items()]
        self.document("parameters", "\n".join(lines), static=True)

    def trial(self, trial: Trial, cfg, *, cost: float, sq_error: float) -> None:
        """One trial: its script's phases, joints and tip path, the map after the dump, the pile, the metrics."""
        self.require_started("trial")
        if trial.trace is None:
            raise UsageError(f"trial {trial.index + 1} carries no trace: run it with trace=True to record it")
        tr, k, t0 = trial.trace, trial.index + 1, self._offset
        self.at(t0, trial=k)
        target = (trial.r_d, trial.theta_d) if not math.isnan(trial.r_d) else (cfg.site.r_d, cfg.site.theta_d)
        if target != self._target:
            self._log_site(cfg, target)
            self._target = target
        at = Times(t0 + tr.times)
        for j, name in enumerate(JOINT_ENTITY):
            self.scalar_columns(f"joint_deg/{JOINT_ENTITY[name]}", np.degrees(tr.q[:, j]), at)
        self.point_columns("world/exec/tip", tr.tip, radius=0.03, at=at)
        # the phases: one staircase per sub-script, and a log line per step change
        steps: dict[str, list[tuple[float, int]]] = {}
        for t, joint, step in tr.phases:
            steps.setdefault(joint, []).append((t, len(steps.get(joint, [])) + 1))
            self.at(t0 + t, trial=k)
            self.say(f"trial {k} +{t:5.2f} s  {SUBSCRIPT_ENTITY.get(joint, joint)}: {step}")
        for joint, seq in steps.items():
            # hold each step until the next one (and the last one to the script's end) on the staircase
            times = [t for t, _ in seq] + [trial.time_s]
            self.scalar_columns(f"script/{SUBSCRIPT_ENTITY.get(joint, joint)}", [i for _, i in seq] + [seq[-1][1]],
                                Times(t0 + np.asarray(times)))
        # the outcome, at the script's end
        self.at(t0 + trial.time_s, trial=k)
        self.lines("world/exec/path", [tr.tip], colours=PATH_RGB, radii=0.01, labels=[f"trial {k}"])
        self.height_map("world/soil/scan", tr.after, colours=MAP_RGB)
        p, q = trial.pile, trial.true
        self.points("world/pile/measured", [[p.x, p.y, p.z]], colours=MEASURED_RGB, radii=0.04,
                    labels=[f"measured r {p.r:.3f} m, theta {math.degrees(p.theta):.1f} deg"])
        self.points("world/pile/true", [[q.x, q.y, q.z]], colours=TRUE_RGB, radii=0.025, labels=["true peak"])
        self._metrics.append((k, cost, trial.time_s, sq_error, trial.predicted_cost))
        for name, v in (("cost", cost), ("time_s", trial.time_s), ("sq_error_m2", sq_error),
                        ("predicted_cost", trial.predicted_cost)):
            if np.isfinite(v):
                self.scalar(f"metrics/{name}", v)
        self.say(f"trial {k} ({trial.source}): {trial.outcome}, time {trial.time_s:.2f} s, pile r {p.r:.3f} m theta "
                 f"{math.degrees(p.theta):.1f} deg, cost {cost:.2f}" + (" FAILED" if trial.failed else ""),
                 WARN if trial.failed else INFO)
        self._offset = t0 + trial.time_s + TRIAL_GAP_S

    def _log_site(self, cfg, target: tuple[float, float]) -> None:
        site = cfg.site
        r_d, th = target
        z = float(site.side_z)
        self.points("world/target", [_polar(r_d, th, z - 0.3)], colours=TARGET_RGB, radii=0.05,
                    labels=[f"target r {r_d:.2f} m, theta {math.degrees(th):.0f} deg"])
        # the truck's side as a square bed of the configured half-width about the target (display only)
        w = float(site.half_width)
        radial, tangent = np.array([math.cos(th), math.sin(th), 0.0]), np.array([-math.sin(th), math.cos(th), 0.0])
        c = np.array(_polar(r_d, th, z))
        corners = [c + a * w * radial + b * w * tangent for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1), (-1, -1))]
        self.lines("world/truck", [corners], colours=TRUCK_RGB, radii=0.01, labels=["truck side (moved away, §6.2)"])


class TrialRecorder(TruckRecorder):
    """A ``task: dump_trial`` episode recorded as :class:`TruckRecorder` records a tuning run, from the episode's
    hooks: ``started(sim, cfg)`` (the task's ``reset``), ``dug(index, trial)`` after each trial,
    ``finished(result)`` (a :class:`~excavsim.tasks.dump_trial.trial.Trial`, a tuning run, or None when the
    episode raised). The file is open from the start, so an episode that fails before its first trial
    still leaves a valid recording.

    Args:
        path: the ``.rrd`` file to write.
    """

    def __init__(self, path: str | os.PathLike | None, *, live: str | None = None):
        super().__init__(path, seed=None, live=live)  # the seed: the world's

    def begin(self, sim, cfg):
        super().begin(cfg)
        return sim

    def dug(self, index: int, trial: Trial) -> None:
        if not self._metrics:  # known once the fixed dig is done
            self.parameters(trial.params, f"The first trial's parameters ({trial.source})")
        self.trial(trial, self.cfg, cost=trial_cost(trial, self.cfg), sq_error=placement_error2(trial, self.cfg))

    def finished(self, result=None) -> None:
        super().finished(None if result is None else getattr(result, "tuning_trials", [result]))
