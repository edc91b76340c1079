"""Touch-down as the testbed had it (Singh 1995 §7.1.3, Fig. 104): the trial, its failure rate, the figure.

:func:`touch_down` runs the executor's touch-down (move above the entry, descend until the F/T says
contact) on flat soil in a fresh world and stops it where the dig would start; the world's truth
(the links' angles, the soil's contact) judges it. :func:`failure_table` runs it over seeds, soils
and entries and counts the failures: contact declared with the bucket in the air, contact missed
(the descent ended without it), and contact found at a depth off the truth by more than
``DEPTH_TOL_M``. :func:`calibrate_give` measures the joints' unseen give as a testbed would (known
loads, surveyed tip poses), :func:`coping_executor` is executor.yaml with the touch-down's coping on
(the quiet wait and that give), and :func:`fig104` draws touch-downs' F/T readings and tip heights
against time. The numbers: docs/notes/2026-12-02-touch-down.md.

Privileged truth, for figures and the notes: the loop wires world and mind; nothing of the robot's
mind reads these records.
"""

from __future__ import annotations

import dataclasses
import math
import pathlib
from collections.abc import Sequence

import numpy as np

from excavsim import constants
from excavsim.config import ExecutorConfig, SceneConfig, load_config, load_executor_config, load_scene_config
from excavsim.execution.dig import DigExecutor
from excavsim.handoff.dig import DigPlan
from excavsim.planning.figures import _figure, _save
from excavsim.robot.extract import arm_from_model
from excavsim.sensing.ft import ForceSensor
from excavsim.world.simulation import Simulation

SCENE_TESTBED_YAML = constants.CONFIGS_DIR / "scene_testbed.yaml"
SURFACE_Z_M = 0.5  # configs/scene.yaml's flat fill [m]
ENTRIES_M = (1.7, 1.9, 2.1, 2.3)  # radial distances of the entries tried (the planner's digs enter at 1.6-2.3 m)
ENTRY_PITCH_RAD = math.radians(50.0)  # a planned entry's pitch (the default trench's first dig enters at 50 deg)
DEPTH_TOL_M = 0.015  # a contact found further than this from the truth is a failure (§7.1.2's maps are ~2 cm)
AIR_N, AIR_TICKS = 10.0, 5  # contact declared with the soil's force under 10 N for 5 ticks: in the air


class _Reached(Exception):
    """Raised from the executor's phase hook where the dig would start: the touch-down is over."""


@dataclasses.dataclass
class TouchTrial:
    """One touch-down, as the mind saw it and as the world was.

    Attributes:
        outcome: "ok", "in air" (contact declared, the bucket clear of the soil), "missed" (no contact),
            "depth" (contact found off the truth by more than ``DEPTH_TOL_M``) or the executor's outcome.
        error_m: the mind's surface height at the entry (found tip height plus its sink calibration)
            minus the true one [m]; NaN without contact.
        penetration_m: the bucket's deepest point below the surface when contact was declared [m].
        t, tip_z, ft, soil_n: per control step: time [s], the true tip height [m], the F/T force's
            magnitude the mind read [N], the soil's force on the bucket (truth) [N].
        t_contact: when contact was declared [s] (NaN: never); t_descent: when the descent started [s].
    """

    seed: int
    soil: str
    entry_m: float
    outcome: str = ""
    error_m: float = math.nan
    penetration_m: float = math.nan
    t_contact: float = math.nan
    t_descent: float = math.nan
    t: list = dataclasses.field(default_factory=list)
    tip_z: list = dataclasses.field(default_factory=list)
    ft: list = dataclasses.field(default_factory=list)
    soil_n: list = dataclasses.field(default_factory=list)


class _Watched:
    """The simulation as the executor sees it, logging every control step's truth and F/T reading."""

    def __init__(self, sim: Simulation, trial: TouchTrial, arm, ft: ForceSensor):
        self._sim, self._trial, self._arm, self._ft = sim, trial, arm, ft
        self._planar = sim.index.planar_qpos
        self.stop_at = math.inf  # simulated time at which to end the trial (set at contact)

    def __getattr__(self, name):
        return getattr(self._sim, name)

    def track(self, target):
        obs = self._sim.track(target)
        tr, sim = self._trial, self._sim
        tr.t.append(obs.time)
        tr.tip_z.append(float(self._arm.forward(sim.data.qpos[self._planar])[1]))
        tr.ft.append(float(np.linalg.norm(self._ft.reading(obs).force_tip)))
        c = sim.contact
        tr.soil_n.append(float(np.linalg.norm(c.force)) if c is not None else 0.0)
        if obs.time >= self.stop_at:
            raise _Reached
        return obs


def entry_plan(x: float, z: float = SURFACE_Z_M, pitch: float = ENTRY_PITCH_RAD) -> DigPlan:
    """A dig entering flat soil at radial distance ``x`` [m]: its entry is all a touch-down reads."""
    poses = np.array([[x, z, pitch], [x - 0.1 * math.cos(0.6), z - 0.1 * math.sin(0.6), pitch]])
    return DigPlan(poses, np.zeros(2, dtype=int), 0.0, 0.0)


def touch_down(seed: int, soil: str, entry_m: float, *, scene: SceneConfig | None = None,
               executor: ExecutorConfig | None = None, after_s: float = 0.0) -> TouchTrial:
    """One touch-down in a fresh world (flat soil, the map exact) and its verdict (see :class:`TouchTrial`);
    the trace goes on ``after_s`` past the contact (into the dig's lead-in)."""
    sim = Simulation(scene=scene, soil=soil, seed=seed)
    cfg = executor or load_executor_config()
    arm = arm_from_model(sim.model)
    trial = TouchTrial(seed, soil, entry_m)
    ft = ForceSensor(sim.model)
    plan = entry_plan(entry_m)
    contact: dict = {}

    def hook(phase, rec):
        if phase == "touch-down":
            trial.t_descent = sim.time
        if phase == "dig":  # contact declared: the truth now
            contact["offset"] = rec.touch_offset_m
            contact["pen"] = float(sim.contact.max_penetration_m) if sim.contact is not None else -1.0
            contact["t"] = sim.time
            watched.stop_at = sim.time + after_s
            if after_s <= 0.0:
                raise _Reached

    watched = _Watched(sim, trial, arm, ft)
    ex = DigExecutor(watched, arm, cfg, ft, sim.index.park)
    try:
        rec = ex.run(plan, on_phase=hook)
    except _Reached:
        pass
    else:
        trial.outcome = "missed" if rec.outcome == "no contact" else rec.outcome
        return trial
    # the truth: where the tip is when the bucket's lowest point meets the flat surface, at the touch pitch
    # the map is the truth here, so the mind's offset (found tip + its sink calibration - expected) is its error
    trial.error_m = contact["offset"]
    trial.t_contact = contact["t"]
    trial.penetration_m = contact["pen"]
    k = int(np.searchsorted(trial.t, trial.t_contact, side="right"))  # the ticks up to the contact
    if max(trial.soil_n[max(0, k - AIR_TICKS):k]) < AIR_N:
        trial.outcome = "in air"
    elif abs(trial.error_m) > DEPTH_TOL_M:
        trial.outcome = "depth"
    else:
        trial.outcome = "ok"
    return trial


@dataclasses.dataclass(frozen=True)
class FailureTable:
    """Touch-down trials over seeds, soils and entries, and their failure counts."""

    label: str
    trials: tuple[TouchTrial, ...]

    def count(self, outcome: str) -> int:
        return sum(t.outcome == outcome for t in self.trials)

    @property
    def failure_rate(self) -> float:
        return 1.0 - self.count("ok") / len(self.trials)

    def row(self) -> str:
        """One Markdown row: trials, in air, missed, depth, other, failure rate, error mean and std [cm]."""
        err = np.array([t.error_m for t in self.trials if math.isfinite(t.error_m)])
        other = len(self.trials) - sum(self.count(k) for k in ("ok", "in air", "missed", "depth"))
        stats = f"{100 * err.mean():+.1f} | {100 * err.std():.1f}" if err.size else "- | -"
        return (f"| {self.label} | {len(self.trials)} | {self.count('in air')} | {self.count('missed')} | "
                f"{self.count('depth')} | {other} | {100 * self.failure_rate:.0f} % | {stats} |")


TABLE_HEADER = ("| world, executor | trials | in air | missed | depth | other | failure rate | error mean [cm] "
                "| error std [cm] |\n|---|---|---|---|---|---|---|---|---|")


def failure_table(label: str, seeds: Sequence[int], soils: Sequence[str], entries: Sequence[float] = ENTRIES_M, *,
                  scene: SceneConfig | None = None, executor: ExecutorConfig | None = None) -> FailureTable:
    """Touch-downs over ``seeds`` x ``soils`` x ``entries`` (see :func:`touch_down`)."""
    trials = tuple(touch_down(s, soil, x, scene=scene, executor=executor)
                   for s in seeds for soil in soils for x in entries)
    return FailureTable(label, trials)


def calibrate_give(scene: SceneConfig, *, entries: Sequence[float] = ENTRIES_M, loads_kg: Sequence[float] = (0.0, 50.0, 100.0),
                   seed: int = 0) -> np.ndarray:
    """The planar joints' give that their encoders miss, per N m of actuator torque (3,) [rad/(N m)], as a
    testbed would calibrate it: the arm held still above each entry with known loads in the bucket, the
    tip's pose surveyed (here: the world's truth, as a total station would give it), the difference
    from the encoders' forward kinematics turned into joint angles through the Jacobian, and each
    joint's angle regressed on its actuator torque through the origin (least squares). The result is
    the executor's ``joint_give_rad_per_nm``."""
    sim0 = Simulation(scene=scene, seed=seed)
    arm = arm_from_model(sim0.model)
    planar = sim0.index.planar_qpos
    act = sim0.index.actuator[[constants.JOINTS.index(j) for j in constants.PLANAR_JOINTS]]
    dq, tau = [], []
    for x in entries:
        pose = np.array([x, SURFACE_Z_M + 0.12, math.radians(10.0)])
        q_target, ok = arm.inverse(pose)
        if not ok:
            continue
        for load in loads_kg:
            sim = Simulation(scene=scene, seed=seed)
            sim.soil_enabled = False
            sim.model.body_mass[sim.index.bucket_body] += load
            target = sim.index.home.copy()
            target[planar] = q_target
            for _ in range(600):
                sim.track(target)
            enc = sim.joint_angles()[planar]
            surveyed = arm.forward(sim.data.qpos[planar])
            dq.append(np.linalg.solve(arm.jacobian(enc), surveyed - arm.forward(enc)))
            tau.append(sim.data.actuator_force[act].copy())
    dq, tau = np.asarray(dq), np.asarray(tau)
    return -np.sum(dq * tau, axis=0) / np.sum(tau * tau, axis=0)


def testbed_scene() -> SceneConfig:
    """``configs/scene_testbed.yaml``: the default scene with the arm's compliance on."""
    return load_config(SCENE_TESTBED_YAML, SceneConfig)


COPING = {"touch_quiet_s": 0.3, "joint_give_rad_per_nm": [9.8e-7, 3.4e-6, 2.0e-5]}  # calibrate_give on the testbed arm


def coping_executor(give: Sequence[float] | None = None) -> ExecutorConfig:
    """executor.yaml with the touch-down's coping on: the quiet wait, and the give compensation (the
    testbed arm's calibration unless ``give`` is given)."""
    update = dict(COPING)
    if give is not None:
        update["joint_give_rad_per_nm"] = list(give)
    return load_executor_config().model_copy(update=update)


def fig104(ctx, path: pathlib.Path) -> str:
    """Fig. 104: touch-downs on flat sand: the F/T reading the executor saw and the tip's true height
    against time from the start of the descent, on the nominal arm, on the testbed arm with the
    executor before it coped, and after."""
    scene = testbed_scene()
    runs = {"nominal arm, executor before": touch_down(ctx.seed, "testbed_sand", 2.1, scene=load_scene_config(),
                                                       after_s=0.5),
            "testbed arm, executor before": touch_down(ctx.seed, "testbed_sand", 2.1, scene=scene, after_s=0.5),
            "testbed arm, executor after": touch_down(ctx.seed, "testbed_sand", 2.1, scene=scene,
                                                      executor=coping_executor(), after_s=0.5)}
    fig = _figure((8.0, 6.5))
    ax_f, ax_z = fig.add_subplot(2, 1, 1), fig.add_subplot(2, 1, 2)
    lines = []
    for k, (name, tr) in enumerate(runs.items()):
        t = np.asarray(tr.t) - tr.t_descent
        sel = t >= -1.5
        ax_f.plot(t[sel], np.asarray(tr.ft)[sel], f"C{k}-", lw=1, label=f"{name}: F/T |F| read")
        ax_f.plot(t[sel], np.asarray(tr.soil_n)[sel], f"C{k}:", lw=1, label=f"{name}: soil force (truth)")
        ax_z.plot(t[sel], 100 * (np.asarray(tr.tip_z)[sel] - SURFACE_Z_M), f"C{k}-", lw=1, label=name)
        if math.isfinite(tr.t_contact):
            for ax in (ax_f, ax_z):
                ax.axvline(tr.t_contact - tr.t_descent, color=f"C{k}", lw=0.6, ls="--")
        lines.append(f"{name}: {tr.outcome}, error {100 * tr.error_m:+.1f} cm, F/T peak "
                     f"{max(tr.ft[int(np.searchsorted(tr.t, tr.t_descent - 1.5)):]):.0f} N")
    ax_f.set_ylabel("|F| [N]")
    ax_f.legend(fontsize=6)
    ax_z.axhline(0.0, color="k", lw=0.6)
    ax_z.set_ylabel("true tip height above the surface [cm]")
    ax_z.set_xlabel("time from the start of the descent [s] (dashed: contact declared)")
    ax_z.legend(fontsize=7)
    ax_f.set_title(f"Fig. 104: touch-down on flat sand (seed {ctx.seed}, entry 2.1 m)", fontsize=10)
    _save(fig, path)
    return "; ".join(lines)
