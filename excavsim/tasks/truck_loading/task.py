"""Truck loading with the 25 t excavator, pass after pass until the truck is full (Rowe 1997 §4, §6).

``task: truck_loading`` of the episode specification (machine ``excavator_25t``). A new task rather than
``task: dump_trial`` with another machine: ``truck`` is one trial of §6.2's experiment on the T3 (the truck
moved away, one dump on the ground, its configuration ``configs/dump_trial.yaml``), this is the loading of a
real truck to full, pass after pass, with its own configuration (``configs/truck_loading.yaml``, the
spec's ``truck_loading:`` overrides) and a pass budget (the spec's ``dig_budget``); keeping them apart
leaves the T3 trial as it was, bit for bit.

Each cycle of the platform's :class:`~excavsim.loop.episode.Episode` is one **pass** (one bucket load):

* look: the pit's scanner maps the pit (:mod:`excavsim.sensing.elevation`) and the bed scanner the truck
  (:func:`~excavsim.tasks.truck_loading.mind.planner.bed_map`); the truck is full (``done``) when the scanned load
  (volume x the soil's density, the density the mind is told: the soil preset's) reaches ``full_fraction``
  of the rated payload, or when one more heaped bucket would overload it by more than half a bucket.
* decide: where to dig next from the pit's map (:func:`~excavsim.tasks.truck_loading.mind.planner.choose_dig`),
  where to dump from the bed's (:func:`~excavsim.tasks.truck_loading.mind.planner.choose_dump`), and the tuned
  parameters (:data:`TUNED`): the computed ones plus noise for the first
  ``initial_passes``, then LWR + the simplex on the passes so far
  (:func:`~excavsim.learning.lwr_tuning.select_action`, §6.2), unless ``tune`` is off. The cost is §6.2's:
  its time is the script's (from the end of the dig until the swing is back, as §6.2 measured), its
  placement the deposit's centre against the aim, plus the graded failure.
* dig: to the dig's start, AutoDig (§4.4, :mod:`excavsim.tasks.truck_loading.mind.autodig`), Rowe's script
  (:mod:`excavsim.execution.rowe_script`: Fig. 4 with Fig. 3's clearance angle, on this machine), the
  soil settles, the bed is scanned again: the pass's deposit centre is measured on the two bed maps.

Metrics per pass (:class:`Pass`) and per truck (:class:`TruckLoad`): time per bucket (to the dig, the dig,
the script; Rowe's "bucket loading cycle" is their sum), soil in the bucket after the dig, soil in the
truck, spillage (what left the bucket and missed the bed: the world's truth), the load's centre offset in
the bed, the placement's cost (§6.2).
"""

from __future__ import annotations

import dataclasses
import math
import time
from typing import Any

import numpy as np

from excavsim.config import get_soil, load_sensing_config
from excavsim.errors import ConfigError, GoalError
from excavsim.execution.rowe_script.geometry import ClearDump, TruckSite
from excavsim.execution.rowe_script.listing import ScriptJoints, rowe_script
from excavsim.execution.rowe_script.params import ScriptRules, compute_params
from excavsim.execution.rowe_script.runner import approach, run_script
from excavsim.execution.rowe_script.timing import ProfileTiming, SwingProfile
from excavsim.handoff.maps import ElevationMap
from excavsim.learning.lwr_tuning import Memory, Objective, select_action
from excavsim.loop.digs import Choice
from excavsim.robot.extract import arm_from_model
from excavsim.sensing.elevation import scan_map
from excavsim.tasks.truck_loading.config import TruckLoadingFile
from excavsim.tasks.truck_loading.mind import planner as plan
from excavsim.tasks.truck_loading.mind.autodig import AutoDigConfig, autodig
from excavsim.tasks.truck_loading.world.truck import TruckSpec, TruckWorld
from excavsim.world.hydraulics import EXCAVATOR_JOINTS
from excavsim.world.scanner import LaserScanner

MACHINES = ("excavator_25t",)
#: The script's joints on the excavator: swing, boom, stick, bucket (the servos' order).
SCRIPT_JOINTS = ScriptJoints(*EXCAVATOR_JOINTS)
#: The parameters tuned online (Rowe 1997 §6.2; which ones here is assumed), in the learner's order:
#: the swing profile's acceleration [rad/s^2] (how hard the machine may swing: faster, or overshooting the
#: truck, §1's "understanding of the machine's own performance abilities"), the dump's radial and swing
#: offsets [m, rad] (added to the aim computed from the scanned fill) and the bucket's opening share that
#: sends the swing back.
TUNED = ("swing_accel", "aim_dr", "aim_dtheta", "return_fraction")
# The learner's outcomes are the deposit's position about this reference, shifted by the pass's aim (the
# aim changes from pass to pass as the bed fills; the error from it is what is learnt).
_REF_R, _REF_THETA = 7.6, math.pi / 2


@dataclasses.dataclass
class Pass:
    """One pass (one bucket load): what was chosen, what it did, how long it took, where the soil went."""

    index: int
    source: str
    x: np.ndarray  # the tuned parameters (TUNED), angles [rad]
    dig_swing: float
    dig_r: float
    aim_r: float
    aim_theta: float
    approach_s: float
    dig_s: float
    script_s: float
    outcome: str
    penetrate_end: str
    drag_end: str
    drag_m: float
    peak_mpa: tuple[float, float, float]
    bucket_m3: float  # in the bucket after the dig (truth)
    dumped_m3: float  # what left the bucket during the script (truth)
    bed_m3: float  # what the bed caught during the script (truth)
    r: float  # the deposit's centre by the bed scans [m, rad]
    theta: float
    boom_trigger: float
    boom_clear: float
    boom_at_swing: float
    cost: float = math.nan
    predicted_cost: float = math.nan

    @property
    def cycle_s(self) -> float:
        """The bucket loading cycle [s]: to the dig, the dig, the swing-dump-return script."""
        return self.approach_s + self.dig_s + self.script_s

    @property
    def spill_m3(self) -> float:
        """What left the bucket and missed the bed [m^3] (truth)."""
        return max(self.dumped_m3 - self.bed_m3, 0.0)

    @property
    def placement_error_m(self) -> float:
        return math.sqrt((self.aim_r - self.r) ** 2 + self.aim_r ** 2 * (self.aim_theta - self.theta) ** 2)


@dataclasses.dataclass(frozen=True)
class TruckTotals:
    """One truck of an episode: its number, the index of its last pass, its passes, its loading time [s]
    (the passes' cycles), the soil in it when it left [m^3] (truth), the spillage [m^3] and the load's centre
    in the bed (along, across) [m] (truth)."""

    number: int
    last_pass: int
    passes: int
    time_s: float
    bed_m3: float
    spill_m3: float
    offset_u_m: float
    offset_v_m: float


@dataclasses.dataclass
class TruckLoad:
    """A truck's loading: its passes, how it ended, and the truck's totals (see :func:`summary`)."""

    machine: str
    soil: str
    tuned: bool
    passes: list[Pass]
    end: str
    reason: str
    bed_m3: float  # truth
    scanned_m3: float
    payload_t: float
    density_kg_m3: float
    spill_m3: float
    offset_u_m: float  # the load's centre in the bed's frame (truth) [m]
    offset_v_m: float
    volume_drift_m3: float
    sim_s: float
    wall_s: float
    trucks: list[TruckTotals] = dataclasses.field(default_factory=list)  # the trucks that filled
    task: str = "truck_loading"

    @property
    def truck_s(self) -> float:
        """Time to load the truck [s]: the passes' cycles."""
        return float(sum(p.cycle_s for p in self.passes))

    @property
    def load_t(self) -> float:
        return self.bed_m3 * self.density_kg_m3 / 1000.0


def truck_spec(f: TruckLoadingFile) -> TruckSpec:
    t = f.truck
    return TruckSpec(x_m=t.x_m, y_m=t.y_m, yaw_deg=t.yaw_deg, length_m=t.length_m, width_m=t.width_m,
                     floor_m=t.floor_m, side_m=t.side_m, payload_kg=1000.0 * t.payload_t)


def autodig_config(f: TruckLoadingFile, relief_pa: float) -> AutoDigConfig:
    a = f.autodig
    return AutoDigConfig(depth_m=a.depth_m, drag_m=a.drag_m, drag_speed_m_s=a.drag_speed_m_s,
                         penetrate_pa=1e6 * a.penetrate_mpa, slow_pa=1e6 * a.slow_mpa, rise_pa=1e6 * a.rise_mpa,
                         full_pa=1e6 * a.full_mpa, full_s=a.full_s, full_depth_m=a.full_depth_m,
                         rise_speed_m_s=a.rise_speed_m_s, relief_pa=relief_pa,
                         attack_deg=a.attack_deg, capture_deg=a.capture_deg)


def script_rules(f: TruckLoadingFile) -> ScriptRules:
    """How the excavator's script parameters are computed (§4.2): the lowest dump clear of the truck's side
    (the pour's and the open bucket's pitch from the file), and the heuristics ("magic numbers" of §4.2,
    assumed): the stick goes out at 40 % of the swing, the arm goes back to the next dig past 60 % of the
    swing's way back, the swing is back within 3 deg; the boom gets ``safety`` of the swing's time to clear.
    No stick condition on the dump and no "continue to dump" step: boom and stick hold the dump pose until
    the swing is on its way back."""
    s = f.script
    return ScriptRules(ClearDump(math.radians(s.pour_pitch_deg), math.radians(s.open_pitch_deg)), stick_fraction=0.4,
                       back_fraction=0.6, stop_tol=math.radians(3.0), safety=s.safety)


def _units(x: np.ndarray) -> np.ndarray:
    """Tuned parameters from the file's units (rad/s^2, m, deg, -) to the script's (rad/s^2, m, rad, -)."""
    x = np.asarray(x, float).copy()
    x[2] = math.radians(x[2])
    return x


class TruckLoadingTask:
    """The truck-loading task (module docstring) as a :class:`~excavsim.loop.episode.Task`.

    Args:
        machine: ``excavator_25t``.
        cfg: ``configs/truck_loading.yaml`` with the spec's overrides, validated.
        soil: a soil preset (default the scene's).
    """

    final_scan = True

    def __init__(self, machine: str, *, cfg: TruckLoadingFile, soil: str | None = None):
        if machine not in MACHINES:
            raise ConfigError(f"machine {machine!r} does not do task truck_loading; allowed: {', '.join(MACHINES)}")
        self.machine, self.cfg, self.soil_name = machine, cfg, soil
        self.wall_limit_s = cfg.wall_limit_s
        t = cfg.tuning
        self.lower, self.upper = _units(t.lower), _units(t.upper)
        self.noise = _units(t.noise)
        if np.any(self.lower > self.upper):
            raise ConfigError("truck_loading: tuning.lower must not exceed tuning.upper")

    # -- the platform's hooks ------------------------------------------------------------------------------
    def reset(self, seed: int, world=None, digs=None) -> tuple:
        if digs is not None:
            raise ConfigError("task truck_loading chooses its own digs (digs must be None)")
        cfg = self.cfg
        self.world = w = world if world is not None else TruckWorld(self.machine, self.soil_name, seed=seed,
                                                                    truck=truck_spec(cfg))
        self.soil = get_soil(self.soil_name or w.scene.soil)
        self.arm = arm_from_model(w.model, joints=EXCAVATOR_JOINTS)
        sensing = load_sensing_config()
        self.scan_cfg = sensing.map.model_copy(update=dict(cell_size_m=cfg.pit_scan_cell_m, calibrate=False))
        scanner_cfg = sensing.scanner.model_copy(update=dict(max_range_m=25.0, n_azimuth=120, n_elevation=120))
        self.scanner = LaserScanner(w.model, w.soil.grid, scanner_cfg, np.random.default_rng((seed, 7)))
        t = w.truck
        self.bed = plan.BedGeometry(t.x_m, t.y_m, t.heading, t.length_m, t.width_m, t.floor_m, cell_m=0.2)
        # the truck across the swing's path: the swing reaches its near end at half its length from its centre
        self.site = TruckSite(math.hypot(t.x_m, t.y_m), math.atan2(t.y_m, t.x_m), t.side_top_m, 0.5 * t.length_m,
                              cfg.script.clearance_m)
        self.rules = script_rules(cfg)
        self.profile = SwingProfile(cfg.script.swing_accel_rad_s2, cfg.script.swing_speed_rad_s)
        self.dig_cfg = autodig_config(cfg, w.spec.relief_pa)
        self.rng = np.random.default_rng((seed, 34))
        # the learner's inputs: the tuned parameters and the pass's context, the swing's travel from the dig to
        # the aim [rad] (not chosen: held at this pass's value in the search; §6.2 kept the start the same, here
        # the dig moves from pass to pass and the swing's time with it)
        self.memory = Memory(len(TUNED) + 1)
        self.objective = Objective(_REF_R, _REF_THETA, cfg.tuning.w1_per_s, cfg.tuning.w2_per_m2,
                                   failure_cost=cfg.tuning.failure_cost, trust_radius=0.25, uncertainty=False)
        self.passes: list[Pass] = []
        self.trucks: list[TruckTotals] = []
        self.v0 = w.volume_account()["total"]
        self.bed_depth: np.ndarray | None = None  # the bed's map after the last pass (None: scan it)
        self.pit: ElevationMap | None = None
        self.t0 = time.perf_counter()
        return w, cfg

    def budget_reason(self, budget: int) -> str:
        return f"pass budget of {budget} spent before the truck was full"

    def park(self) -> None:
        """Nothing: the bucket waits over the dig it came back to; the scanners see past it."""

    def scan(self):
        self.pit, _ = scan_map(self.scanner, self.world.time, self.scan_cfg, 1)
        if self.bed_depth is None:
            self.bed_depth = plan.bed_map(self.world.bed_scanner.scan(), self.bed)
        return self.pit, self.bed_depth

    def assess(self, index, scanned, say):
        self.scanned_m3 = scanned_m3 = plan.map_volume(self.bed_depth, self.bed)
        load_t = scanned_m3 * self.soil.density_kg_m3 / 1000.0
        # full: at full_fraction of the payload, or when another bucket would overload the truck by more than
        # half a heaped bucket (a shallower last cut still fills most of the bucket as it curls: measured)
        heaped_t = 1.25 * self.world.spec.bucket.struck_capacity_m3() * self.soil.density_kg_m3 / 1000.0
        full_t = min(self.cfg.truck.full_fraction, 1.0) * self.cfg.truck.payload_t
        full_t = min(full_t, self.cfg.truck.payload_t - 0.5 * heaped_t)
        say(f"pass {index}: the scans show {scanned_m3:.2f} m^3 in the truck ({load_t:.1f} t of {full_t:.1f} t)")
        if load_t >= full_t:
            self._truck_done(index)
            n = len(self.trucks)
            if n >= self.cfg.tuning.trucks:
                return scanned, ("done", f"truck full by the scans: {load_t:.1f} t of the "
                                         f"{self.cfg.truck.payload_t:g} t payload after {index - 1} passes"
                                 + (f" ({n} trucks)" if n > 1 else ""))
            say(f"truck {n} full ({load_t:.1f} t by the scans): it leaves, an empty one parks in its place")
            self.world.haul()  # the loaded truck leaves; the learner's memory stays (§5: every pass is an experiment)
            self.bed_depth = plan.bed_map(self.world.bed_scanner.scan(), self.bed)
        return scanned, None

    def _truck_done(self, index: int) -> None:
        """Record the truck that just filled: its passes, time, load (truth), spillage and load's centre."""
        w = self.world
        first = self.trucks[-1].last_pass if self.trucks else 0
        ps = self.passes[first:]
        u, v = w.bed.centroid_offset()
        self.trucks.append(TruckTotals(len(self.trucks) + 1, len(self.passes), len(ps),
                                       float(sum(p.cycle_s for p in ps)), w.bed.volume(),
                                       float(sum(p.spill_m3 for p in ps)), u, v))

    def choose(self, emap) -> Choice:
        cfg, w = self.cfg, self.world
        truck_theta = math.atan2(w.truck.y_m, w.truck.x_m)
        dig = plan.choose_dig(emap.height_at, np.radians(cfg.dig.swings_deg), np.asarray(cfg.dig.radii_m),
                              drag_m=cfg.autodig.drag_m, depth_m=cfg.autodig.depth_m, width_m=w.spec.bucket.width_m,
                              floor_z=cfg.dig.floor_z_m, truck_swing=truck_theta)
        ax, ay = plan.choose_dump(self.bed_depth, self.bed, margin_m=1.0)
        aim_r, aim_theta = math.hypot(ax, ay), math.atan2(ay, ax)
        k = len(self.passes)
        pred = math.nan
        base = np.array([cfg.script.swing_accel_rad_s2, 0.0, 0.0, 0.8])
        travel = abs(aim_theta - dig.swing)
        if cfg.tuning.tune and k >= cfg.tuning.initial_passes and len(self.memory) >= 2:
            seen = self.memory.x[:, -1]  # the search stays where the memory has data: the travel clipped to it
            held = float(np.clip(travel, seen.min(), seen.max()))
            sel = select_action(self.memory, self.objective, lower=np.r_[self.lower, held],
                                upper=np.r_[self.upper, held])
            x, pred, source = np.clip(sel.x[:len(TUNED)], self.lower, self.upper), sel.predicted_cost, "learned"
        else:
            x = np.clip(base + self.rng.normal(0.0, 1.0, 4) * self.noise, self.lower, self.upper)
            source = "computed + noise"
        return Choice(dig={"dig": dig, "aim": (aim_r, aim_theta), "x": x, "source": source, "predicted": pred,
                           "travel": travel},
                      note=f"  dig at {math.degrees(dig.swing):.0f} deg, r {dig.start_r:.1f} m "
                           f"({dig.soil_m3:.2f} m^3 on the map); dump at r {aim_r:.2f} m, "
                           f"{math.degrees(aim_theta):.1f} deg ({source})")

    def _surface(self, swing: float):
        emap, half = self.pit, 0.5 * self.world.spec.bucket.width_m
        c, s = math.cos(swing), math.sin(swing)

        def at(r):
            across = np.array([-half, 0.0, half])
            return float(np.median(emap.height_at(r * c - across * s, r * s + across * c)))
        return at

    def execute(self, index, choice):
        w, arm, cfg = self.world, self.arm, self.cfg
        c = choice.dig
        dig: plan.DigChoice = c["dig"]
        x = c["x"]
        surface = self._surface(dig.swing)
        start = np.array([dig.start_r, surface(dig.start_r) + 0.3, math.radians(cfg.autodig.attack_deg)])
        q_start, ok = arm.inverse(start)
        if not ok:
            raise GoalError(f"the dig's start {start.round(2).tolist()} is out of reach")
        approach_s = approach(w, np.r_[dig.swing, q_start], self.profile)
        # the last load of a truck: a shallower, shorter cut, so that the truck is not overloaded (Rowe 1997 §1:
        # "digging a desired amount of soil to avoid overloading the trucks"): depth and drag scaled by the
        # share of a heaped bucket that fits the payload by the scans, at least a quarter (assumed)
        heaped = 1.25 * w.spec.bucket.struck_capacity_m3()
        room = 1000.0 * cfg.truck.payload_t / self.soil.density_kg_m3 - self.scanned_m3
        dig_cfg = self.dig_cfg
        if room < heaped:
            share = max(0.25, room / heaped)
            dig_cfg = dataclasses.replace(dig_cfg, drag_m=dig_cfg.drag_m * share, depth_m=dig_cfg.depth_m * share)
        run = autodig(w, arm, dig.swing, dig.start_r, surface, dig_cfg)
        loaded = w.volume_account()
        aim_r, aim_theta = c["aim"]
        boom_speed = float(w.spec.joint_speed_limits(run.q_end)[1])
        swing = SwingProfile(float(x[0]), cfg.script.swing_speed_rad_s)
        params = compute_params(arm, self.site, self.rules, ProfileTiming(swing, boom_speed), run.q_end[1:4], dig.swing,
                                dump_at=(aim_r + x[1], aim_theta + x[2]), return_pose=q_start, return_fraction=x[3])
        sr = run_script(w, rowe_script(params, SCRIPT_JOINTS), SCRIPT_JOINTS, profile=swing, tick_clock=True)
        w.soil.settle_all()
        after = w.volume_account()
        before_depth = self.bed_depth
        self.bed_depth = plan.bed_map(w.bed_scanner.scan(), self.bed)
        dx, dy, _ = plan.deposit_centre(before_depth, self.bed_depth, self.bed)
        p = Pass(index=index, source=c["source"], x=np.asarray(x, float), dig_swing=dig.swing, dig_r=dig.start_r,
                 aim_r=aim_r, aim_theta=aim_theta, approach_s=approach_s, dig_s=run.duration_s,
                 script_s=sr.duration, outcome=sr.outcome, penetrate_end=run.penetrate_end, drag_end=run.drag_end,
                 drag_m=run.drag_m, peak_mpa=tuple(float(v) / 1e6 for v in run.peak_pa),
                 bucket_m3=loaded["bucket"], dumped_m3=loaded["bucket"] - after["bucket"],
                 bed_m3=after["bed"] - loaded["bed"], r=math.hypot(dx, dy), theta=math.atan2(dy, dx),
                 boom_trigger=params.boom_trigger, boom_clear=params.boom_clear,
                 boom_at_swing=sr.angle_at("swing to truck", SCRIPT_JOINTS.boom),
                 predicted_cost=c["predicted"])
        failed = self._failed(p)
        r_rel, th_rel = _REF_R + (p.r - p.aim_r), _REF_THETA + (p.theta - p.aim_theta)
        # §6.2's time: from the end of the dig until the swing is back (the part the tuned parameters act on)
        p.cost = float(self.objective.cost(p.script_s, r_rel, th_rel, failed))
        self.memory.add(np.r_[p.x, c["travel"]], p.script_s, r_rel, th_rel, failed)
        self.passes.append(p)
        return (p,), None

    def _failed(self, p: Pass) -> float:
        """§5.4.1's failure as a share in [0, 1]: 1 when the script did not end or ``spill_fail_fraction`` of the
        load missed the truck, the spilled share of that below it (assumed: a graded failure, so that the
        learner, whose cost is §6.2's time and placement, also sees the spillage that Rowe's §3 counts)."""
        if p.outcome != "end":
            return 1.0
        return float(min(p.spill_m3 / (self.cfg.tuning.spill_fail_fraction * max(p.bucket_m3, 1e-9)), 1.0))

    def after(self, index, choice, dug, say):
        (p,) = dug
        say(f"  pass {index}: {p.cycle_s:.1f} s (to dig {p.approach_s:.1f}, dig {p.dig_s:.1f} [{p.drag_end}], "
            f"swing-dump-return {p.script_s:.1f}); bucket {p.bucket_m3:.2f} m^3, into the truck {p.bed_m3:.2f}, "
            f"spilled {p.spill_m3:.3f}; placed {100 * p.placement_error_m:.0f} cm from the aim; cost {p.cost:.1f}")
        if p.outcome != "end":
            return "timeout", f"the loading script did not end in pass {index} ({p.outcome})"
        return None

    def result(self, end, reason, wall_s) -> TruckLoad:
        w = self.world
        acc = w.volume_account()
        u, v = w.bed.centroid_offset()
        return TruckLoad(machine=self.machine, soil=self.soil_name or w.scene.soil, tuned=self.cfg.tuning.tune, passes=list(self.passes),
                         end=end, reason=reason, bed_m3=acc["bed"],
                         scanned_m3=plan.map_volume(self.bed_depth, self.bed) if self.bed_depth is not None else 0.0,
                         payload_t=self.cfg.truck.payload_t, density_kg_m3=self.soil.density_kg_m3,
                         spill_m3=float(sum(p.spill_m3 for p in self.passes)), offset_u_m=u, offset_v_m=v,
                         volume_drift_m3=acc["total"] - self.v0, sim_s=w.time, wall_s=wall_s,
                         trucks=list(self.trucks))


# -- the platform's views of a result ------------------------------------------------------------------------
def episode_recorder(path: str | None, *, live: str | None = None):
    """The Rerun recorder of a truck-loading episode to ``path`` and/or streamed to the viewer at ``live`` (a
    gRPC URL): the machine moving, the truck, its bed's fill after each pass, the pit and the per-pass metrics
    (:class:`~excavsim.tasks.truck_loading.recording.TruckLoadingRecorder`)."""
    from excavsim.tasks.truck_loading.recording import TruckLoadingRecorder

    return TruckLoadingRecorder(path, live=live)


def summary(res: TruckLoad) -> dict[str, Any]:
    """A truck's metrics as a flat dict (a campaign row, ``regress``'s sample): ``end``/``reason``, ``digs``
    (passes), ``bucket_l_per_pass`` (in the bucket after the dig), ``truck_l`` and ``truck_t`` (in the bed,
    truth), ``scanned_l``, ``spill_l`` (left the bucket, missed the bed), ``spill_fraction`` (of what was
    dumped), ``cycle_s`` (mean time per bucket), ``truck_s`` (time for the truck), ``dig_s``, ``script_s``
    (means), ``offset_u_cm``/``offset_v_cm`` (the load's centre in the bed, truth), ``placement_error_cm``
    (mean), ``cost`` (mean, §6.2), ``first_cost``/``last_cost`` (means of the first and last three passes),
    ``volume_change_m3`` (the account's drift), ``sim_s``, ``wall_s``, ``trucks`` (how many filled). When
    a truck filled, ``truck_s``, ``truck_t``, ``truck_l``, ``spill_l``, ``passes_per_truck`` and the load's
    centre (its magnitude) are means over the trucks that filled."""
    ps = res.passes
    n = len(ps)
    dumped = sum(p.dumped_m3 for p in ps)

    def mean(key):
        return float(np.mean([getattr(p, key) for p in ps])) if ps else math.nan
    k = min(3, n)
    out = {
        "task": res.task, "machine": res.machine, "soil": res.soil, "tuned": int(res.tuned), "end": res.end,
        "reason": res.reason, "digs": n, "bucket_l_per_pass": 1000 * mean("bucket_m3"), "truck_l": 1000 * res.bed_m3,
        "truck_t": res.load_t, "scanned_l": 1000 * res.scanned_m3, "spill_l": 1000 * res.spill_m3,
        "spill_fraction": res.spill_m3 / dumped if dumped > 0 else 0.0, "cycle_s": mean("cycle_s"),
        "truck_s": res.truck_s, "dig_s": mean("dig_s"), "script_s": mean("script_s"),
        "offset_u_cm": 100 * res.offset_u_m, "offset_v_cm": 100 * res.offset_v_m,
        "placement_error_cm": 100 * mean("placement_error_m"), "cost": mean("cost"),
        "first_cost": float(np.mean([p.cost for p in ps[:k]])) if ps else math.nan,
        "last_cost": float(np.mean([p.cost for p in ps[-k:]])) if ps else math.nan,
        "volume_change_m3": res.volume_drift_m3, "sim_s": res.sim_s, "wall_s": res.wall_s,
        "trucks": len(res.trucks), "passes_per_truck": float(n),
    }
    if res.trucks:  # the per-truck numbers are means over the trucks that filled (not a part-loaded last one)
        t = res.trucks
        out.update(truck_s=float(np.mean([x.time_s for x in t])),
                   truck_t=float(np.mean([x.bed_m3 for x in t])) * res.density_kg_m3 / 1000.0,
                   truck_l=1000 * float(np.mean([x.bed_m3 for x in t])),
                   spill_l=1000 * float(np.mean([x.spill_m3 for x in t])),
                   passes_per_truck=float(np.mean([x.passes for x in t])),
                   offset_u_cm=100 * float(np.mean([abs(x.offset_u_m) for x in t])),
                   offset_v_cm=100 * float(np.mean([abs(x.offset_v_m) for x in t])),
                   last_truck_s=t[-1].time_s, first_truck_s=t[0].time_s)
    return out


def dig_rows(res: TruckLoad) -> list[dict[str, Any]]:
    """One row per pass: the dig, the aim, the times, the volumes [l], the placement and the cost."""
    rows = []
    for p in res.passes:
        rows.append({"dig": p.index, "source": p.source, "dig_swing_deg": math.degrees(p.dig_swing), "dig_r_m": p.dig_r,
                     "aim_r_m": p.aim_r, "aim_theta_deg": math.degrees(p.aim_theta), "approach_s": p.approach_s,
                     "dig_s": p.dig_s, "script_s": p.script_s, "cycle_s": p.cycle_s, "drag_end": p.drag_end,
                     "drag_m": p.drag_m, "peak_stick_mpa": p.peak_mpa[1], "bucket_l": 1000 * p.bucket_m3,
                     "truck_l": 1000 * p.bed_m3, "spill_l": 1000 * p.spill_m3, "r_m": p.r,
                     "theta_deg": math.degrees(p.theta), "placement_error_cm": 100 * p.placement_error_m,
                     "cost": p.cost, "swing_accel_rad_s2": p.x[0], "aim_dr_m": p.x[1],
                     "aim_dtheta_deg": math.degrees(p.x[2]), "return_fraction": p.x[3],
                     "boom_trigger_deg": math.degrees(p.boom_trigger), "boom_clear_deg": math.degrees(p.boom_clear),
                     "boom_at_swing_deg": math.degrees(p.boom_at_swing), "outcome": p.outcome})
    return rows


def format_run(res: TruckLoad) -> str:
    """The truck's table: one line per pass and the truck's totals, beside Rowe's numbers."""
    lines = [f"Truck loading, {res.machine}, soil {res.soil}, {'tuned' if res.tuned else 'untuned'} "
             f"(Rowe 1997 §4, §6.2): {res.end}: {res.reason}",
             "| pass | source | cycle [s] | dig [s] | script [s] | bucket [m^3] | truck [m^3] | spill [m^3] "
             "| placement [cm] | cost |", "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for p in res.passes:
        lines.append(f"| {p.index} | {p.source} | {p.cycle_s:.1f} | {p.dig_s:.1f} | {p.script_s:.1f} | "
                     f"{p.bucket_m3:.2f} | {p.bed_m3:.2f} | {p.spill_m3:.3f} | {100 * p.placement_error_m:.0f} | "
                     f"{p.cost:.1f} |")
    s = summary(res)
    lines.append(f"\n{s['digs']} passes, {s['cycle_s']:.1f} s per bucket, {s['truck_s']:.0f} s per truck "
                 f"({max(len(res.trucks), 1)} truck(s)); "
                 f"{res.bed_m3:.2f} m^3 ({res.load_t:.1f} t) in the truck of a {res.payload_t:g} t payload, "
                 f"spilled {res.spill_m3:.3f} m^3 ({100 * s['spill_fraction']:.1f} %); the load's centre "
                 f"{100 * res.offset_u_m:+.0f} cm along, {100 * res.offset_v_m:+.0f} cm across the bed; "
                 f"volume account drift {res.volume_drift_m3:.1e} m^3")
    for t in res.trucks:
        lines.append(f"truck {t.number}: {t.passes} passes, {t.time_s:.0f} s, {t.bed_m3:.2f} m^3, spilled "
                     f"{t.spill_m3:.3f} m^3, centre {100 * t.offset_u_m:+.0f} / {100 * t.offset_v_m:+.0f} cm")
    if s["digs"]:
        shift_s = 8 * 3600.0
        trucks = shift_s / s["truck_s"]
        faster = shift_s / (s["truck_s"] - 2.0 * s.get("passes_per_truck", s["digs"]))
        lines.append(f"Rowe 1997: 15-20 s per bucket; 2 s less a bucket = 26 more trucks a shift. Here "
                     f"{s['cycle_s']:.1f} s a bucket and {s['truck_s']:.0f} s a truck: {trucks:.0f} trucks in "
                     f"an 8 h shift without hauling waits; 2 s less a bucket gives {faster - trucks:.0f} more")
    return "\n".join(lines)
