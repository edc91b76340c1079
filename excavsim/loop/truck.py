"""Truck loading by the mass-excavation script, self-tuned online (001_0de172b0d6b3614b.txt §4.3, §5, §6.2).

One **trial** (:func:`run_trial`) is the experiment of §6.2 on the T3: a fresh world (the same soil
every trial, as the thesis' simulation ensured), the same dig every time (``dig_path`` of
``configs/truck.yaml``, followed through IK at the dig face), a scan of the box, then the
mass-excavation script (:mod:`excavsim.execution.mass_script`) swings, dumps on the ground at the
target (the truck moved away, §6.2) and swings back to the dig face; the soil settles and the box is
scanned again. The outcomes are the script's execution time (from the end of digging until the
swing is back at the dig face, §6.2) and the pile's position, measured by the mind from the two
elevation maps (:func:`pile_position`, Fig. 11): the highest point of the deposit locates the pile,
and the weighted centre of its peak region (below the map's cell size) is its position, in polar
coordinates about the swing axis. A trial that leaves more than ``1 - min_dumped_fraction`` of the
load in the bucket, or whose script does not end, is a failure (§5.4.1) and costs ``failure_cost`` more.

:func:`tune` runs N trials online: the first ``initial_trials`` from the computed parameters plus
small noise, then each from :func:`~excavsim.learning.lwr_tuning.select_action` on the memory so far,
and writes the learning curve (Fig. 12) and a CSV table.
"""

from __future__ import annotations

import csv
import dataclasses
import math
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import yaml

from excavsim import constants
from excavsim.config import load_robot_config, load_sensing_config
from excavsim.errors import ExcavsimError
from excavsim.execution.mass_script import (BOOM, BUCKET, STICK, SWING, TUNED, MassParams, TimingModel, TruckSite,
                                            compute_params, follow_path, mass_script, run_joint_script)
from excavsim.handoff.maps import ElevationMap
from excavsim.learning.lwr_tuning import Memory, Objective, select_action
from excavsim.loop.rig import go_to
from excavsim.robot.extract import arm_from_model
from excavsim.sensing.elevation import build_map
from excavsim.world.scanner import LaserScanner
from excavsim.world.simulation import Simulation

TRUCK_YAML = constants.CONFIGS_DIR / "truck.yaml"


@dataclasses.dataclass(frozen=True)
class TruckConfig:
    """``configs/truck.yaml`` (see the file for every number and its source); angles in radians here."""

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

    @property
    def objective(self) -> Objective:
        return Objective(self.site.r_d, self.site.theta_d, self.w1, self.w2, self.min_support, self.support_penalty,
                         self.margin, self.failure_cost, self.trust_radius)


def load_truck_config(path: str | Path | None = None) -> TruckConfig:
    """Read ``configs/truck.yaml`` (or ``path``)."""
    path = Path(path) if path else TRUCK_YAML
    try:
        d = yaml.safe_load(path.read_text())
        tg, tr, ln = d["target"], d["truck"], d["learning"]
        site = TruckSite(float(tg["r_m"]), math.radians(tg["theta_deg"]), float(tr["side_z_m"]),
                         float(tr["half_width_m"]), float(tr["clearance_m"]), float(tr["dump_z_m"]))
        dig = np.array(d["dig_path"], dtype=float)
        dig[:, 2] = np.radians(dig[:, 2])
        return TruckConfig(site, math.radians(d["dig_swing_deg"]), float(d["dig_speed_m_s"]), dig,
                           float(d["latency_s"]), math.radians(d["open_pitch_deg"]), float(d["cost"]["w1_per_s"]),
                           float(d["cost"]["w2_per_m2"]), int(ln["initial_trials"]),
                           math.radians(ln["initial_noise_deg"]), tuple(ln["widths_log2"]),
                           float(ln["min_support"]), float(ln["support_penalty"]), float(ln["margin"]),
                           float(ln["failure_cost"]), float(ln["min_dumped_fraction"]), float(ln["trust_radius"]))
    except (OSError, KeyError, TypeError, ValueError, IndexError) as exc:
        raise ExcavsimError(f"{path}: not a truck configuration: {exc!r}") from exc


def timing_model(sim: Simulation, cfg: TruckConfig) -> TimingModel:
    """The machine model of §4.2 from the servos' speed limits and gain (configs/robot.yaml)."""
    robot = load_robot_config()
    speed = dict(zip(constants.JOINTS, sim.rate_limit))
    return TimingModel({j: float(speed[j]) for j in (SWING, BOOM, STICK, BUCKET)}, robot.setpoint_gain_per_s,
                       cfg.latency)


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


class Scanner:
    """The box's scanner and the map builder, as the loop uses them around a trial."""

    def __init__(self, sim: Simulation, seed: int):
        self.sim = sim
        self.cfg = load_sensing_config()
        self.scanner = LaserScanner(sim.model, sim.soil.grid, self.cfg.scanner, np.random.default_rng((seed, 7)))

    def map(self) -> ElevationMap:
        images = [self.scanner.scan(self.sim.time) for _ in range(self.cfg.map.n_scans)]
        return build_map(images, self.scanner.geometry, self.cfg.map)[0]


@dataclasses.dataclass
class Trial:
    """One trial's action and outcomes."""

    index: int
    params: MassParams
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

    @property
    def failed(self) -> bool:
        """§5.4.1: a trial that did not do its task (the script did not end, or it left more than
        ``1 - min_dumped_fraction`` of the load in the bucket) is a failure, stored with a high cost."""
        return self.outcome != "end" or self.dumped_m3 < self.min_dumped_fraction * self.loaded_m3


def dig(sim: Simulation, cfg: TruckConfig, arm) -> np.ndarray:
    """The fixed dig of §6.2: to the first pose at the dig face, then along the dig path. Returns q (6,)."""
    start, ok = arm.inverse(cfg.dig_path[0])
    if not ok:
        raise ExcavsimError(f"the dig path's first pose {cfg.dig_path[0]} is out of reach")
    go_to(sim, np.r_[cfg.dig_swing, start, 0.0, 0.0], _MoveCfg())
    return follow_path(sim, arm, cfg.dig_path, cfg.dig_speed, cfg.dig_swing)


@dataclasses.dataclass(frozen=True)
class _MoveCfg:
    settle_tol_rad: float = 0.01
    move_timeout_s: float = 15.0


def nominal_params(cfg: TruckConfig, *, seed: int = 0) -> MassParams:
    """The computed parameters (§4.2) for this site, on the dig's end pose (one dig to find it)."""
    sim = Simulation(seed=seed)
    arm = arm_from_model(sim.model)
    q = dig(sim, cfg, arm)
    return compute_params(arm, cfg.site, timing_model(sim, cfg), q[1:4], cfg.dig_swing, open_pitch=cfg.open_pitch)


def run_trial(params: MassParams, cfg: TruckConfig, *, seed: int = 0, index: int = 0, source: str = "") -> Trial:
    """One dig-swing-dump trial (see the module docstring)."""
    wall = time.perf_counter()
    sim = Simulation(seed=seed)
    arm = arm_from_model(sim.model)
    scanner = Scanner(sim, seed)
    dig(sim, cfg, arm)
    loaded = sim.truth.volumes.bucket
    before_map = scanner.map()
    before_true = sim.soil.grid.heights.copy()
    run = run_joint_script(sim, mass_script(params))
    sim.settle_soil()
    after_map = scanner.map()
    min_theta = cfg.dig_swing + 0.5 * (cfg.site.theta_d - cfg.dig_swing)
    pile = pile_position(before_map, after_map, min_theta)
    true = true_pile(sim, before_true, min_theta)
    dumped = loaded - sim.truth.volumes.bucket
    return Trial(index, params, run.duration, pile, true, run.outcome, dumped, loaded, time.perf_counter() - wall,
                 source, min_dumped_fraction=cfg.min_dumped_fraction)


def tuned_bounds(base: MassParams) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of the seven tuned parameters around the computed ones (assumed: +-25 deg, the lead 0-50 deg,
    the return fraction 0.3-1.0), in :data:`~excavsim.execution.mass_script.TUNED` order."""
    x = base.tuned()
    d = math.radians(25.0)
    lo = np.array([x[0] - d, x[1] - d, 0.0, x[3] - d, x[4] - d, x[5] - d, 0.3])
    hi = np.array([x[0] + d, x[1] + d, math.radians(50.0), x[3] + d, x[4] + d, x[5] + d, 1.0])
    return lo, hi


def retargeted(cfg: TruckConfig, r_m: float, theta: float) -> TruckConfig:
    """``cfg`` with the dump target moved to (r_m [m], theta [rad])."""
    return dataclasses.replace(cfg, site=dataclasses.replace(cfg.site, r_d=r_m, theta_d=theta))


def tune(trials: int, cfg: TruckConfig | None = None, *, seed: int = 0,
         progress: Callable[[Trial], None] | None = None, learn: bool = True,
         retarget: tuple[int, float, float] | None = None) -> list[Trial]:
    """Run ``trials`` trials online (see the module docstring); returns them in order.

    ``learn=False`` is the untuned baseline: every trial from the computed parameters plus the same small
    noise. ``retarget=(k, r_m, theta_rad)`` moves the dump target before trial ``k`` (0-based): the
    parameters are computed again for the new target and the memory is kept (it maps actions to
    outcomes, whatever the target); only the objective changes."""
    cfg = cfg or load_truck_config()
    base = nominal_params(cfg, seed=seed)
    lo, hi = tuned_bounds(base)
    rng = np.random.default_rng((seed, 12))
    memory = Memory(len(TUNED))
    out: list[Trial] = []
    scale = np.array([cfg.initial_noise] * 6 + [cfg.initial_noise / math.radians(100.0)])  # fraction: /100
    for k in range(trials):
        if retarget is not None and k == retarget[0]:
            cfg = retargeted(cfg, retarget[1], retarget[2])
            base = nominal_params(cfg, seed=seed)
            lo, hi = tuned_bounds(base)
        pred, width = math.nan, math.nan
        if not learn or k < cfg.initial_trials or len(memory) < 2:
            x = np.clip(base.tuned() + rng.normal(0.0, 1.0, len(TUNED)) * scale, lo, hi)
            source = "computed + noise"
        else:
            sel = select_action(memory, cfg.objective, lower=lo, upper=hi)
            x, pred, width, source = sel.x, sel.predicted_cost, sel.width, "learned"
        trial = run_trial(base.with_tuned(x), cfg, seed=seed, index=k, source=source)
        trial.predicted_cost, trial.width = pred, width
        trial.r_d, trial.theta_d = cfg.site.r_d, cfg.site.theta_d
        memory.add(x, trial.time_s, trial.pile.r, trial.pile.theta, float(trial.failed))
        out.append(trial)
        if progress is not None:
            progress(trial)
    return out


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


def write_results(trials: list[Trial], cfg: TruckConfig, out: Path) -> tuple[Path, Path]:
    """The CSV table (one row per trial) and Fig. 12's learning curve (PNG) into ``out``."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out.mkdir(parents=True, exist_ok=True)
    obj = cfg.objective
    rows = []
    for t in trials:
        err2 = placement_error2(t, cfg)
        row = {"trial": t.index + 1, "source": t.source, "cost": trial_cost(t, cfg), "time_s": t.time_s,
               "r_m": t.pile.r, "theta_deg": math.degrees(t.pile.theta), "sq_error_m2": err2,
               "true_r_m": t.true.r, "true_theta_deg": math.degrees(t.true.theta), "outcome": t.outcome,
               "failed": int(t.failed), "target_r_m": trial_objective(t, cfg).r_d,
               "target_theta_deg": math.degrees(trial_objective(t, cfg).theta_d),
               "loaded_l": 1e3 * t.loaded_m3, "dumped_l": 1e3 * t.dumped_m3, "predicted_cost": t.predicted_cost,
               "kernel_width": t.width, "wall_s": t.wall_s}
        row.update({f"{n}{'' if n == 'return_fraction' else '_deg'}": v
                    for n, v in t.params.degrees().items() if n in TUNED})
        rows.append(row)
    csv_path = out / "tune.csv"
    with csv_path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        for row in rows:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in row.items()})
    n = np.arange(1, len(rows) + 1)
    fig, ax = plt.subplots(3, 1, figsize=(6, 7), sharex=True)
    for a, key, label in zip(ax, ("cost", "time_s", "sq_error_m2"), ("cost", "time [s]", "squared error [m^2]")):
        a.plot(n, [r[key] for r in rows], "o-", ms=3)
        a.axvline(cfg.initial_trials + 0.5, color="grey", lw=0.8, ls="--")
        a.set_ylabel(label)
    ax[0].set_title(f"Self-tuned truck loading (Fig. 12 of 001_0de172b0d6b3614b.txt): target r = {obj.r_d} m, "
                    f"theta = {math.degrees(obj.theta_d):.0f} deg", fontsize=8)
    ax[-1].set_xlabel("trial")
    fig.tight_layout()
    png = out / "learning_curve.png"
    fig.savefig(png, dpi=120)
    plt.close(fig)
    return csv_path, png
