"""Truck loading by the mass-excavation script, self-tuned online (Rowe 1997 §4.3, §5, §6.2).

One **trial** (:func:`run_trial`) is the experiment of §6.2 on the T3: a fresh world (the same soil
every trial, as the thesis' simulation ensured), the same dig every time (``dig_path`` of
``configs/dump_trial.yaml``, followed through IK at the dig face), a scan of the box, then the
mass-excavation script (:mod:`excavsim.execution.rowe_script`) swings, dumps on the ground at the
target (the truck moved away, §6.2) and swings back to the dig face; the soil settles and the box is
scanned again. The outcomes are the script's execution time (from the end of digging until the
swing is back at the dig face, §6.2) and the pile's position, measured by the mind from the two
elevation maps (:func:`pile_position`, Fig. 11): the highest point of the deposit locates the pile,
and the weighted centre of its peak region (below the map's cell size) is its position, in polar
coordinates about the swing axis. A trial that leaves more than ``1 - min_dumped_fraction`` of the
load in the bucket, or whose script does not end, is a failure (§5.4.1) and costs ``failure_cost`` more.

The tuning over trials (:func:`~excavsim.tasks.dump_trial.tuning.tune`, ``excavsim tune``) is
:mod:`excavsim.tasks.dump_trial.tuning`; the campaign over seeds and soils is
:mod:`excavsim.tasks.dump_trial.campaign`. This module keeps what a trial and its judging need: the
configuration, the script's joints and heuristics on the T3, the dig, the scans and the pile, the task,
the cost of §6.2, the tuned parameters and the tuner's bounds.
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar
import math
from pathlib import Path

import numpy as np

from excavsim import constants
from excavsim.config import load_robot_config, load_sensing_config
from excavsim.errors import GoalError, UsageError
from excavsim.execution.paths import follow_path
from excavsim.execution.rowe_script.geometry import HeightDump, TruckSite
from excavsim.execution.rowe_script.listing import ScriptJoints, rowe_script
from excavsim.execution.rowe_script.params import RoweParams, ScriptRules, compute_params
from excavsim.execution.rowe_script.runner import run_script
from excavsim.execution.rowe_script.timing import TimingModel
from excavsim.handoff.maps import ElevationMap
from excavsim.learning.lwr_tuning import Objective
from excavsim.loop.digs import Choice
from excavsim.loop.episode import Episode
from excavsim.rig.core import go_to
from excavsim.robot.extract import arm_from_model
from excavsim.sensing.elevation import scan_map
from excavsim.tasks.dump_trial.config import TRUCK_YAML, TruckFile, load_truck_file
from excavsim.world.scanner import LaserScanner
from excavsim.world.simulation import Simulation

#: The script's joints on the T3 (Rowe 1997 §6.2's listing): swing = waist, boom = shoulder, stick = elbow,
#: bucket = wrist pitch; the wrist's yaw and roll stay level.
SCRIPT_JOINTS = ScriptJoints(*constants.JOINTS[:4], level=constants.JOINTS[4:])
#: The seven tuned parameters of §6.2, in the order of the learner's input vector; angles [rad] except the
#: :data:`FRACTIONS` [-]. Which seven is not legible in the thesis' listing, so the choice here is
#: **assumed** (the ones that set the time and where the soil lands). The bucket-open lead ``open_lead`` is
#: computed, not tuned: on the T3 the stick's trigger (``stick_fraction``) is the one that sets when the
#: dump begins (see :mod:`~excavsim.execution.rowe_script.listing`), and it is tuned instead.
TUNED = ("boom_trigger", "swing_dump", "stick_fraction", "boom_dump", "stick_dump", "bucket_open", "return_fraction")
#: The tuned parameters that are fractions of a motion [-] (the others are angles [rad]).
FRACTIONS = ("stick_fraction", "return_fraction")


@dataclasses.dataclass(frozen=True)
class TruckConfig:
    """``configs/dump_trial.yaml`` (see the file for every number and its source); angles in radians here."""

    site: TruckSite
    dig_swing: float
    dig_speed: float
    dig_path: np.ndarray
    latency: float
    open_pitch: float
    w1: float
    w2: float
    initial_trials: int
    initial_noise: float
    widths_log2: tuple[int, int]
    min_support: float
    support_penalty: float
    margin: float
    failure_cost: float
    min_dumped_fraction: float
    trust_radius: float
    expected_cost: bool = False
    retarget_trials: int = 1
    stick_fraction_range: tuple[float, float] = (0.1, 0.9)
    return_fraction_range: tuple[float, float] = (0.3, 1.0)
    angle_range: float = math.radians(25.0)

    @property
    def objective(self) -> Objective:
        return Objective(self.site.r_d, self.site.theta_d, self.w1, self.w2, self.min_support, self.support_penalty,
                         self.margin, self.failure_cost, self.trust_radius, uncertainty=self.expected_cost)


def load_truck_config(path: str | Path | None = None) -> TruckConfig:
    """Read ``configs/dump_trial.yaml`` (or ``path``), validated (:class:`~excavsim.tasks.dump_trial.config.TruckFile`), in radians."""
    return truck_config(load_truck_file(path))


def truck_config(f: TruckFile) -> TruckConfig:
    """The run-time configuration (radians) of a validated ``configs/dump_trial.yaml``."""
    tg, tr, ln, rg = f.target, f.truck, f.learning, f.ranges
    site = TruckSite(tg.r_m, math.radians(tg.theta_deg), tr.side_z_m, tr.half_width_m, tr.clearance_m, tr.dump_z_m)
    dig = np.array(f.dig_path, dtype=float)
    dig[:, 2] = np.radians(dig[:, 2])
    return TruckConfig(site, math.radians(f.dig_swing_deg), f.dig_speed_m_s, dig, f.latency_s,
                       math.radians(f.open_pitch_deg), f.cost.w1_per_s, f.cost.w2_per_m2, ln.initial_trials,
                       math.radians(ln.initial_noise_deg), tuple(ln.widths_log2), ln.min_support, ln.support_penalty,
                       ln.margin, ln.failure_cost, ln.min_dumped_fraction, ln.trust_radius, ln.expected_cost,
                       ln.retarget_trials, tuple(rg.stick_fraction), tuple(rg.return_fraction),
                       math.radians(rg.angles_deg))


def timing_model(sim: Simulation, cfg: TruckConfig) -> TimingModel:
    """The machine model of §4.2 from the servos' speed limits and gain (configs/robot.yaml), by the joints'
    roles in the script."""
    robot = load_robot_config()
    speed = dict(zip(constants.JOINTS, sim.rate_limit))
    j = SCRIPT_JOINTS
    roles = {"swing": j.swing, "boom": j.boom, "stick": j.stick, "bucket": j.bucket}
    return TimingModel({role: float(speed[name]) for role, name in roles.items()}, robot.setpoint_gain_per_s,
                       cfg.latency)


def script_rules(cfg: TruckConfig) -> ScriptRules:
    """How the T3's parameters are computed (§4.2): the dump at the site's height with the bucket open at
    ``open_pitch``, and the heuristics ("magic numbers" of §4.2, assumed): the stick goes out halfway
    through the swing (``stick_fraction`` 0.5) and the dump waits for it to be 70 % out; boom and stick
    continue when the bucket is 60 % open; the swing returns when the bucket is 80 % open
    (``return_fraction`` 0.8); the arm goes back to the dig past 75 % of the swing's way back (clear of the
    truck); the swing is back within 2 deg."""
    return ScriptRules(HeightDump(open_pitch=cfg.open_pitch), stick_fraction=0.5, back_fraction=0.75,
                       stop_tol=math.radians(2.0), return_fraction=0.8, stick_open_fraction=0.7,
                       dumped_fraction=0.6)


@dataclasses.dataclass(frozen=True)
class Pile:
    """A pile's peak: world (x, y, z) [m], polar r [m] and theta [rad] about the swing axis."""

    x: float
    y: float
    z: float

    @property
    def r(self) -> float:
        return math.hypot(self.x, self.y)

    @property
    def theta(self) -> float:
        return math.atan2(self.y, self.x)


def deposit_peak(x: np.ndarray, y: np.ndarray, before: np.ndarray, after: np.ndarray, min_theta: float, *,
                 peak_fraction: float = 0.5, radius_m: float = 0.2) -> Pile:
    """The pile's position from the deposit ``after - before`` on a grid (rows along y), below the cell size.

    The highest cell of the deposit smoothed over 3 x 3 cells (assumed: one cell's noise does not make
    the peak), among the cells whose polar angle is above ``min_theta`` [rad] (the dump side, away from
    the dig face), locates the peak (§6.2: "the highest point of the pile"); the position returned is
    the centre of the peak region, the cells within ``radius_m`` of that peak whose smoothed deposit is
    at least ``peak_fraction`` of the peak's, each weighted by its deposit above that level (§5.2's
    "center of mass" of the pile on a terrain grid, restricted to the peak so that spilled soil does not
    pull it; assumed). A cell-quantized peak would move in whole cells; the weighted centre moves
    continuously with the pile. ``z`` is the peak cell's height after the dump."""
    d = np.asarray(after, dtype=float) - np.asarray(before, dtype=float)
    pad = np.pad(d, 1, mode="edge")
    smooth = sum(pad[i:i + d.shape[0], j:j + d.shape[1]] for i in range(3) for j in range(3)) / 9.0
    xx, yy = np.meshgrid(x, y)
    side = np.arctan2(yy, xx) > min_theta
    masked = np.where(side, smooth, -np.inf)
    i, j = np.unravel_index(int(np.argmax(masked)), masked.shape)
    level = peak_fraction * smooth[i, j]
    near = side & (np.hypot(xx - xx[i, j], yy - yy[i, j]) <= radius_m)
    w = np.where(near, np.clip(smooth - level, 0.0, None), 0.0)
    if smooth[i, j] <= 0.0 or w.sum() <= 0.0:
        return Pile(float(xx[i, j]), float(yy[i, j]), float(after[i, j]))
    return Pile(float(np.sum(w * xx) / w.sum()), float(np.sum(w * yy) / w.sum()), float(after[i, j]))


def pile_position(before: ElevationMap, after: ElevationMap, min_theta: float) -> Pile:
    """Fig. 11: the pile's peak measured from two elevation maps (the mind's view)."""
    x, y = before.centres()
    return deposit_peak(x, y, before.heights, after.heights, min_theta)


def true_pile(sim: Simulation, before: np.ndarray, min_theta: float) -> Pile:
    """The true pile's peak from the world's heights (privileged: tests and logs)."""
    g = sim.soil.grid
    x, y = g.xy(np.arange(g.shape[0]), np.arange(g.shape[1]))
    return deposit_peak(np.asarray(x, float), np.asarray(y, float), before, g.heights, min_theta)


def missed_volume(sim: Simulation, before: np.ndarray, cfg: TruckConfig, min_theta: float) -> float:
    """The soil the dump put beside the truck (privileged truth, for reports) [m^3]: the deposit on the
    dump side (polar angle above ``min_theta``) farther than the bed's half-width from the target. The
    truck is moved away (§6.2), so a bed of the truck's half-width centred on the target stands for it
    (assumed: the thesis gives the bed's width only, Fig. 3); soil outside it would have missed the truck."""
    g = sim.soil.grid
    x, y = (np.asarray(v, float) for v in g.xy(np.arange(g.shape[0]), np.arange(g.shape[1])))
    xx, yy = np.meshgrid(x, y)
    tx, ty = cfg.site.r_d * math.cos(cfg.site.theta_d), cfg.site.r_d * math.sin(cfg.site.theta_d)
    outside = (np.arctan2(yy, xx) > min_theta) & (np.hypot(xx - tx, yy - ty) > cfg.site.half_width)
    deposit = np.clip(g.heights - before, 0.0, None)
    return float(deposit[outside].sum() * g.cell_area)


class BoxMapper:
    """The box's scanner and the map builder, as the loop uses them around a trial."""

    def __init__(self, sim: Simulation, seed: int):
        self.sim = sim
        self.cfg = load_sensing_config()
        self.scanner = LaserScanner(sim.model, sim.soil.grid, self.cfg.scanner, np.random.default_rng((seed, 7)))

    def map(self) -> ElevationMap:
        return scan_map(self.scanner, self.sim.time, self.cfg.map)[0]


@dataclasses.dataclass
class Trial:
    """One trial's action and outcomes."""

    task: ClassVar[str] = "dump_trial"  # the task whose episode result it is
    index: int
    params: RoweParams
    time_s: float
    pile: Pile
    true: Pile
    outcome: str
    dumped_m3: float
    loaded_m3: float
    wall_s: float
    source: str
    predicted_cost: float = math.nan
    width: float = math.nan
    min_dumped_fraction: float = 0.9
    r_d: float = math.nan      # the target the trial was run for (set by tune)
    theta_d: float = math.nan
    trace: TrialTrace | None = None  # kept when a recording asks for it (run_trial's trace)
    missed_m3: float = math.nan  # soil dumped beside the truck's bed (privileged truth; see missed_volume)
    sim_s: float = math.nan  # the trial's simulated time, the fixed dig included [s]
    objective: Objective | None = None  # the cost of §6.2 the trial was run under (its target and weights)

    @property
    def failed(self) -> bool:
        """§5.4.1: a trial that did not do its task (the script did not end, or it left more than
        ``1 - min_dumped_fraction`` of the load in the bucket) is a failure, stored with a high cost."""
        return self.outcome != "end" or self.dumped_m3 < self.min_dumped_fraction * self.loaded_m3


def dig(sim: Simulation, cfg: TruckConfig, arm) -> np.ndarray:
    """The fixed dig of §6.2: to the first pose at the dig face, then along the dig path. Returns q (6,)."""
    start, ok = arm.inverse(cfg.dig_path[0])
    if not ok:
        raise GoalError(f"the dig path's first pose {cfg.dig_path[0]} is out of reach")
    go_to(sim, np.r_[cfg.dig_swing, start, 0.0, 0.0], _MoveCfg())
    return follow_path(sim, arm, cfg.dig_path, cfg.dig_speed, cfg.dig_swing)


@dataclasses.dataclass(frozen=True)
class _MoveCfg:
    settle_tol_rad: float = 0.01
    move_timeout_s: float = 15.0


def nominal_params(cfg: TruckConfig, *, seed: int = 0, soil: str | None = None) -> RoweParams:
    """The computed parameters (§4.2) for this site, on the dig's end pose (one dig to find it)."""
    sim = Simulation(soil=soil, seed=seed)
    arm = arm_from_model(sim.model)
    q = dig(sim, cfg, arm)
    return compute_params(arm, cfg.site, script_rules(cfg), timing_model(sim, cfg), q[1:4], cfg.dig_swing)


@dataclasses.dataclass(frozen=True)
class TrialTrace:
    """What a recording shows of one trial, all of it the mind's (sensed joints, scanned maps).

    Attributes:
        times: (n,) seconds since the script started, one per control tick.
        q: (n, 6) joint angles [rad].
        tip: (n, 3) the bucket tip in the world [m] (the robot's own kinematics on the sensed joints).
        phases: (time [s] since the script started, sub-script joint, step name), every step change.
        before, after: the elevation maps before the script and after the dump settled.
    """

    times: np.ndarray
    q: np.ndarray
    tip: np.ndarray
    phases: list[tuple[float, str, str]]
    before: ElevationMap
    after: ElevationMap


class _Tracing:
    """The servos with every observation kept (for :class:`TrialTrace`)."""

    def __init__(self, sim: Simulation):
        self.sim, self.obs = sim, []

    def __getattr__(self, name):
        return getattr(self.sim, name)

    def observe(self):
        o = self.sim.observe()
        self.obs.append((o.time, np.array(o.q, dtype=float)))
        return o

    def track(self, target):
        o = self.sim.track(target)
        self.obs.append((o.time, np.array(o.q, dtype=float)))
        return o


class TruckTask:
    """One trial of truck loading (§6.2, see the module docstring) as a task of the platform's
    :class:`~excavsim.loop.episode.Episode`: the fixed dig loads the bucket when the episode is reset;
    the one cycle scans the site (the map before), runs the mass-excavation script with ``params``
    (the cycle's dig), lets the soil settle and scans again; the result is the :class:`Trial` with the
    pile measured on the maps (and on the truth, for reports). Its hooks' arguments: ``started(sim,
    cfg)``, ``scanned(1, map before, None)``, ``planned(1, None, script)``, ``dug(1, trial)``,
    ``finished(trial)``.

    Args:
        params, cfg, index, source, soil, trace: as :func:`run_trial`'s; ``params`` None runs the
            computed parameters (§4.2) on this trial's own dig (:func:`nominal_params` without its
            separate world: the same numbers for the same seed and soil).
    """

    final_scan = False
    wall_limit_s = math.inf

    def __init__(self, params: RoweParams | None, cfg: TruckConfig, *, index: int = 0, source: str = "",
                 soil: str | None = None, trace: bool = False):
        self.params, self.cfg, self.index, self.source = params, cfg, index, source
        self.soil, self.trace = soil, trace

    def reset(self, seed: int, world: Simulation | None = None, digs=None) -> tuple:
        if digs is not None:
            raise UsageError("a truck-loading trial runs its mass-excavation script; no dig source can be given "
                             "(digs must be None)")
        q = self.new_world(seed, world)
        if self.params is None:
            self.params = self.computed(q)
        self.trial: Trial | None = None
        return self.sim, self.cfg

    def new_world(self, seed: int, world: Simulation | None = None) -> np.ndarray:
        """A trial's world (a fresh one of ``seed`` unless given), scanner and fixed dig; the joint angles at
        the dig's end. Every trial starts from such a world (§6.2)."""
        self.sim = sim = world if world is not None else Simulation(soil=self.soil, seed=seed)
        self.arm = arm_from_model(sim.model)
        self.scanner = BoxMapper(sim, seed)
        q = dig(sim, self.cfg, self.arm)
        self.loaded = sim.truth.volumes.bucket
        return q

    def computed(self, q: np.ndarray) -> RoweParams:
        """The parameters computed for the site (§4.2) from this world's dig, ended at joint angles ``q``."""
        return compute_params(self.arm, self.cfg.site, script_rules(self.cfg), timing_model(self.sim, self.cfg),
                              q[1:4], self.cfg.dig_swing)

    def budget_reason(self, budget: int) -> str:
        return "the trial's script ran"

    def park(self) -> None:
        """Nothing: the site is scanned with the loaded bucket at the dig's end."""

    def scan(self):
        self.before_map = self.scanner.map()
        return self.before_map, None

    def assess(self, index, scanned, say):
        self.before_true = self.sim.soil.grid.heights.copy()
        return scanned, None

    def choose(self, emap) -> Choice:
        return Choice(rowe_script(self.params, SCRIPT_JOINTS))

    def execute(self, index, choice):
        sim, cfg = self.sim, self.cfg
        servos = _Tracing(sim) if self.trace else sim
        script = choice.dig
        run = run_script(servos, script, SCRIPT_JOINTS)
        sim.settle_soil()
        after_map = self.scanner.map()
        min_theta = cfg.dig_swing + 0.5 * (cfg.site.theta_d - cfg.dig_swing)
        pile = pile_position(self.before_map, after_map, min_theta)
        true = true_pile(sim, self.before_true, min_theta)
        dumped = self.loaded - sim.truth.volumes.bucket
        out = Trial(self.index, self.params, run.duration, pile, true, run.outcome, dumped, self.loaded, math.nan,
                    self.source, min_dumped_fraction=cfg.min_dumped_fraction, r_d=cfg.site.r_d,
                    theta_d=cfg.site.theta_d, missed_m3=missed_volume(sim, self.before_true, cfg, min_theta),
                    sim_s=float(sim.time), objective=cfg.objective)
        if self.trace:
            t = np.array([o[0] for o in servos.obs]) - run.start
            q = np.stack([o[1] for o in servos.obs])
            keep = (t >= 0.0) & (t <= run.duration + 1e-9)
            t, q = t[keep], q[keep]
            pose = self.arm.forward(q[:, 1:4])
            tip = np.stack([pose[:, 0] * np.cos(q[:, 0]), pose[:, 0] * np.sin(q[:, 0]), pose[:, 1]], axis=1)
            joints = [sub.joints[0] for sub in script.subscripts]
            phases = [(tr.time - run.start, joints[tr.subscript], tr.name) for tr in run.transitions]
            out.trace = TrialTrace(t, q, tip, phases, self.before_map, after_map)
        self.trial = out
        return (out,), None

    def after(self, index, choice, dug, say):
        return None

    def result(self, end, reason, wall_s) -> Trial | None:
        if self.trial is not None:
            self.trial.wall_s = wall_s
        return self.trial


def run_trial(params: RoweParams, cfg: TruckConfig, *, seed: int = 0, index: int = 0, source: str = "",
              soil: str | None = None, trace: bool = False) -> Trial:
    """One dig-swing-dump trial (see the module docstring): the platform's
    :class:`~excavsim.loop.episode.Episode` of a :class:`TruckTask`, one cycle; ``trace`` keeps a
    :class:`TrialTrace`."""
    episode = Episode(TruckTask(params, cfg, index=index, source=source, soil=soil, trace=trace), dig_budget=1)
    episode.reset(seed)
    return episode.run()


def tuned_bounds(base: RoweParams, cfg: TruckConfig | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of the seven tuned parameters (in :data:`TUNED` order): the
    angles within ``ranges.angles_deg`` of the computed ones, the fractions in their ``ranges`` (assumed;
    configs/dump_trial.yaml), and the boom at the dump never below its clearance angle over the truck's side
    (§5.4.1: bounds from the worksite's geometry; Fig. 3). With the truck moved away (§6.2) nothing stops a
    lower boom, and without this bound the learner lowered it 25 deg, into where the truck's side would be."""
    cfg = cfg or load_truck_config()
    x = base.values(TUNED)
    lo, hi = x - cfg.angle_range, x + cfg.angle_range
    k = TUNED.index("boom_dump")
    lo[k] = min(max(lo[k], base.boom_clear_dump), x[k])
    for name, (a, b) in (("stick_fraction", cfg.stick_fraction_range), ("return_fraction", cfg.return_fraction_range)):
        k = TUNED.index(name)
        lo[k], hi[k] = a, b
    return lo, hi


def noise_scale(cfg: TruckConfig) -> np.ndarray:
    """The size of the initial trials' noise per tuned parameter: ``initial_noise`` [rad] on the angles,
    ``initial_noise`` / 100 deg on the fractions (2 deg -> 0.02)."""
    return np.array([cfg.initial_noise / math.radians(100.0) if n in FRACTIONS else cfg.initial_noise
                     for n in TUNED])


def retargeted(cfg: TruckConfig, r_m: float, theta: float) -> TruckConfig:
    """``cfg`` with the dump target moved to (r_m [m], theta [rad])."""
    return dataclasses.replace(cfg, site=dataclasses.replace(cfg.site, r_d=r_m, theta_d=theta))


def trial_objective(trial: Trial, cfg: TruckConfig) -> Objective:
    """The objective the trial was run for (its own target when the target moved during the run)."""
    if math.isnan(trial.r_d):
        return cfg.objective
    return retargeted(cfg, trial.r_d, trial.theta_d).objective


def trial_cost(trial: Trial, cfg: TruckConfig) -> float:
    """The measured cost of a trial, a failure's included (§5.4.1)."""
    return float(trial_objective(trial, cfg).cost(trial.time_s, trial.pile.r, trial.pile.theta, float(trial.failed)))


def placement_error2(trial: Trial, cfg: TruckConfig) -> float:
    """The squared placement error ``(r_d - r)^2 + r_d^2 (theta_d - theta)^2`` [m^2] of a trial."""
    o = trial_objective(trial, cfg)
    return (o.r_d - trial.pile.r) ** 2 + o.r_d ** 2 * (o.theta_d - trial.pile.theta) ** 2
