"""Loading from a pile in MuJoCo (Singh 1995 §3.5, §4.1-4.2, §7.2.1, Fig. 107's cycle).

The world is :class:`~excavsim.tasks.pile_loading.world.scene.LoadingWorld`: the front loader or the front shovel
(MJCF models with the sizes of :mod:`excavsim.robot.loaders`, ``configs/pile_loading_planar.yaml``) beside a pile in
a lane one bucket wide, with the world's soil model (cutting, the wedge-model forces of eq. 8 with its
truth terms, bearing, filling, pouring, settlement) and laser scanner. One episode repeats the cycle:

1. **scan**: ``n_scans`` range images of the world's scanner, calibrated, median-filtered and binned into
   the elevation map (:func:`~excavsim.sensing.elevation.scan_map`); the map gives three 2-D sections
   (:func:`map_sections`): per column the median across the lane's middle (``|y| < section_half_width``),
   and across each side band beyond it;
2. **plan**: :func:`excavsim.tasks.pile_loading.mind.planner.plan` on the middle section: the loading action (k, alpha)
   with d1 maximized and the smallest reachable radius, all of §4.1-4.2's constraints, the shovel's base
   placed between digs; when the middle holds no dig of minimal utility, on the side bands, and the one
   whose dig is the largest is dug (:func:`choose_section`: soil left along a kerb is still the pile's);
3. **execute by script** (:mod:`excavsim.tasks.pile_loading.mind.script`): the shovel's base drives to its
   planned place; the bucket goes to the pre-entry pose (the approach line's backward extension of the
   floor's length, which the collision constraint keeps above the surface); the planned path (approach,
   arc, lift-out), sampled every ``path_step`` and turned into joint set-points by the machine's inverse
   kinematics, is played at ``tip_speed``; the base backs off, carries the load to the truck's place
   behind the lane (the ``carry`` keyframe) and dumps it there (``dump``);
4. **settle** the whole lane (the world's settlement to the angle of repose).

The episode ends when the planner finds no dig of minimal utility on any section of the map (the reason
gives the map's soil left above the ground, :func:`map_soil_m3`), after ``max_digs``, when the physics
diverges or a planned pose is out of the machine's reach (the reason says which); the pile counts as
removed when the lane holds at most ``tolerance_fraction`` of it (privileged truth, for the report).

The volume account (privileged truth, :class:`SoilAccount`): soil leaves the lane either in the bucket,
poured at the truck during the dump (**delivered**), or any other way, chiefly cut soil that a full bucket
pushes ahead (the world's surcharge spill) over the lane's ends or sides (**spilled**). The world keeps
both in one spoil account; the loop splits it by the phase in which it grew, so lane + bucket + delivered +
spilled stays the pile's volume to round-off. Units per dig and the efficiency count the delivered soil only.

Simplifications (stated): the lane is one bucket wide, so the world is the thesis' 2-D section extruded
across it; the servos are position servos; the script is open loop in time (no touch-down, no force
conditions); the loader dumps by backing off and tipping behind the lane rather than into a raised truck,
and the shovel drives back to the same place instead of swinging (the models have no swing joint).
"""

from __future__ import annotations

import dataclasses
import math
import pathlib
from typing import Any, ClassVar, Protocol

import numpy as np

from excavsim.config import load_sensing_config
from excavsim.errors import ConfigError, Diverged, ExcavsimError, GoalError, UsageError
from excavsim.handoff.maps import ElevationMap
from excavsim.loop.digs import Choice
from excavsim.loop.episode import Episode
from excavsim.sensing.elevation import scan_map
from excavsim.tasks.pile_loading import planar as ld
from excavsim.tasks.pile_loading.config import LOADING_MUJOCO_YAML, LoadingMujocoConfig, PileLane, load_loading_mujoco_config
from excavsim.tasks.pile_loading.mind import script as ls
from excavsim.tasks.pile_loading.mind import planner as lp
from excavsim.tasks.pile_loading.world.scene import MACHINES, LoadingWorld
from excavsim.world.scanner import LaserScanner

CONFIG_PATH = LOADING_MUJOCO_YAML


# ---------------------------------------------------------------------------------------------- configuration
def load_mujoco_config(path: str | pathlib.Path | None = None) -> LoadingMujocoConfig:
    """The MuJoCo loading configuration (default ``configs/pile_loading.yaml``), validated
    (:class:`~excavsim.tasks.pile_loading.config.LoadingMujocoConfig`)."""
    return load_loading_mujoco_config(path)


# ---------------------------------------------------------------------------------------------- observers
class LoadingObserver(Protocol):
    """What a recorder sees of a loading episode: the platform episode's hooks
    (:class:`~excavsim.handoff.episode.EpisodeObserver`) with the loading task's arguments (dig indices
    from 1; the loop never imports the recorder)."""

    def started(self, world: LoadingWorld, machine: str) -> None: ...
    def scanned(self, index: int, emap: ElevationMap, terrain: lp.PileSection) -> None: ...
    def planned(self, index: int, plan: lp.LoadingPlan, poses: np.ndarray) -> None: ...
    def stepped(self, world: LoadingWorld) -> None: ...
    def dug(self, index: int, dig: MujocoDig) -> None: ...
    def finished(self, run: MujocoRun) -> None: ...


# ---------------------------------------------------------------------------------------------- results
@dataclasses.dataclass
class MujocoDig:
    """One dig in MuJoCo: the plan, what the planner predicted and what the world did [m^3].

    ``planned_m3`` is the planner's swept area times the lane's width, ``section`` the map section it was
    planned on; ``bucket_m3`` the soil in the bucket at the end of the lift-out, ``delivered_m3`` what the
    bucket poured at the truck, ``spilled_m3`` what left the lane otherwise during this cycle (see the module
    docstring), ``peak_force_n`` the largest soil force on the bucket during the dig (the wedge model's cutting
    force with bearing, friction and the load's weight), all privileged truth but the plan.
    """

    action: lp.LoadingAction
    base_x: float
    planned_m3: float
    bucket_m3: float
    delivered_m3: float
    spilled_m3: float
    lane_m3: float
    scripts: list[ls.ScriptResult]
    tip_path: np.ndarray
    planned_path: np.ndarray
    peak_force_n: float
    section: str = "middle"


@dataclasses.dataclass
class MujocoRun:
    """An episode: its digs, why it ended, the lane's soil at the start and the end [m^3], the drift of the volume
    account (lane + bucket + delivered + spilled minus the start's [m^3]), the bucket's heaped capacity [m^3] and
    width [m], and the soil the last map showed above the ground (the mind's view of what is left) [m^3]."""

    task: ClassVar[str] = "pile_loading"  # the task whose episode result it is
    machine: str
    capacity_m3: float
    width_m: float
    digs: list[MujocoDig]
    reason: str
    start_m3: float
    end_m3: float
    total_drift_m3: float
    tolerance_fraction: float
    sim_time_s: float
    map_end_m3: float = math.nan
    end: str = ""  # the episode's end: done (no dig of minimal utility left), no_dig, budget or diverged
    wall_time_s: float = math.nan

    @property
    def delivered_m3(self) -> float:
        return float(sum(d.delivered_m3 for d in self.digs))

    @property
    def spilled_m3(self) -> float:
        return float(sum(d.spilled_m3 for d in self.digs))

    @property
    def removed_fraction(self) -> float:
        return 1.0 - self.end_m3 / self.start_m3

    @property
    def done(self) -> bool:
        """Whether the lane holds at most ``tolerance_fraction`` of the pile."""
        return self.end_m3 <= self.tolerance_fraction * self.start_m3

    def per_dig(self) -> float:
        """Delivered soil per dig [m^3]."""
        return self.delivered_m3 / len(self.digs) if self.digs else 0.0

    def efficiency(self) -> float:
        """Delivered soil per dig over the bucket's heaped capacity (§7.2.1)."""
        return self.per_dig() / self.capacity_m3


class SoilAccount:
    """The world's spoil split into delivered and spilled (privileged truth; see the module docstring).

    A world step hook: the spoil's growth during a step is delivered while ``dumping`` (the bucket over the
    truck, pouring) and spilled otherwise. ``delivered + spilled`` equals the world's spoil at every step.
    """

    def __init__(self) -> None:
        self.delivered = 0.0
        self.spilled = 0.0
        self.dumping = False
        self._spoil = 0.0

    def reset(self, world: LoadingWorld) -> None:
        self.delivered = self.spilled = 0.0
        self._spoil = world.volumes().spoil

    def __call__(self, world: LoadingWorld) -> None:
        spoil = world.volumes().spoil
        grown, self._spoil = spoil - self._spoil, spoil
        if self.dumping:
            self.delivered += grown
        else:
            self.spilled += grown


# ---------------------------------------------------------------------------------------------- the pieces
def pile_section(world: LoadingWorld, pile: PileLane) -> tuple[np.ndarray, np.ndarray]:
    """A trapezoid (x, z) with faces at the world soil's angle of repose."""
    run = pile.height / math.tan(world.soil.soil.repose)
    x = np.array([pile.foot, pile.foot + run, pile.foot + run + pile.top, pile.foot + 2 * run + pile.top])
    g = world.soil.grid
    if x[-1] > g.x1 - 0.1:
        raise ConfigError(f"a pile {pile.height} m high with a {pile.top} m top from x = {pile.foot} m ends at "
                          f"x = {x[-1]:.2f} m, beyond the lane's end at {g.x1 - 0.1:.2f} m")
    return x, np.array([0.0, pile.height, pile.height, 0.0])


def make_scanner(world: LoadingWorld, cfg: LoadingMujocoConfig, seed: int) -> LaserScanner:
    base = load_sensing_config().scanner
    scfg = base.model_copy(update=cfg.scanner.model_dump())
    return LaserScanner(world.model, world.soil.grid, scfg, np.random.default_rng((seed, 7)))


def scan_section(world: LoadingWorld, scanner: LaserScanner, cfg: LoadingMujocoConfig
                 ) -> tuple[ElevationMap, lp.PileSection]:
    """Scan, build the map, and the planner's middle section (:func:`map_sections`)."""
    emap, _ = scan_map(scanner, world.time, load_sensing_config().map, cfg.n_scans)
    return emap, map_sections(emap, cfg.section_half_width)["middle"]


SECTIONS = ("middle", "near side", "far side")


def map_sections(emap: ElevationMap, half_width: float) -> dict[str, lp.PileSection]:
    """The map's 2-D sections (:data:`SECTIONS`): per column the median height over the rows with
    ``|y| < half_width`` (the middle), ``y <= -half_width`` (the near side) and ``y >= half_width`` (the far
    side); a side with no row is left out. Negative heights (map noise) are the ground."""
    xs, ys = emap.centres()
    bands = {"middle": np.abs(ys) < half_width, "near side": ys <= -half_width, "far side": ys >= half_width}
    return {name: lp.PileSection(xs, np.maximum(np.median(emap.heights[rows], axis=0), 0.0), emap.cell)
            for name, rows in bands.items() if rows.any()}


def map_soil_m3(emap: ElevationMap, width: float, ground: float) -> float:
    """The soil the map shows more than ``ground`` [m] above the ground (a thinner layer is ground, as the
    planner's ``LoadingRules.ground``), over the lane's ``width`` [m]: per column the mean over the rows."""
    excess = np.maximum(emap.heights - ground, 0.0)
    return float(excess.mean(axis=0).sum() * emap.cell * width)


def choose_section(machine, sections: dict[str, lp.PileSection], rules: lp.LoadingRules
                   ) -> tuple[str, lp.PileSection, lp.LoadingPlan]:
    """The section to dig and its plan: the middle's when it holds a dig of minimal utility, else the side
    band's whose dig is the largest; when no section has one, the middle's plan (no action) with a reason
    that names every section's."""
    plans = {"middle": lp.plan(machine, sections["middle"], rules)}
    if plans["middle"].action is not None:
        return "middle", sections["middle"], plans["middle"]
    for name in SECTIONS[1:]:
        if name in sections:
            plans[name] = lp.plan(machine, sections[name], rules)
    dug = [n for n, p in plans.items() if p.action is not None]
    if dug:
        best = max(dug, key=lambda n: plans[n].volume)
        return best, sections[best], plans[best]
    plan = plans["middle"]
    if any(p.reason != "no pile left" for p in plans.values()):
        def best(p: lp.LoadingPlan) -> str:
            v = p.cell_volume[np.isfinite(p.cell_volume)]
            return "no pile" if p.reason == "no pile left" else f"best {v.max() if v.size else 0.0:.3f} m^2"
        plan.reason = (f"no dig of minimal utility ({100 * rules.min_fraction:.0f} % of capacity) on any section ("
                       + ", ".join(f"{n}: {best(p)}" for n, p in plans.items()) + ")")
    return "middle", sections["middle"], plan


def dig_poses(action: lp.LoadingAction, terrain: lp.PileSection, rules: lp.LoadingRules, floor: float, *,
              step: float, lift_extra: float) -> tuple[np.ndarray, np.ndarray]:
    """Tip poses (N, 3) of one planned dig, dense, and their phase (N,): -1 pre-entry (the approach line's
    backward extension of the floor's length), 0 approach, 1 arc, 2 lift-out; the attitude is the planner's
    (:func:`~excavsim.tasks.pile_loading.mind.planner.floor_angle`)."""
    a = action
    ca, sa = math.cos(a.alpha), math.sin(a.alpha)
    s = np.concatenate([np.arange(-floor, 0.0, step), np.arange(0.0, a.d1, step), [a.d1]])
    line = np.stack([a.entry_x + s * ca, a.h - s * sa, np.full(s.size, -a.alpha)], axis=1)
    phase = [np.where(s < 0, -1, 0)]
    _, _, cx, cz = lp.arc_centre(a.entry_x, a.h, a.alpha, a.d1, a.r)
    total = rules.exit_heading + a.alpha
    turn = np.linspace(0.0, total, max(2, int(math.ceil(a.r * total / step)) + 1))[1:]
    psi = -a.alpha + turn
    arc = np.stack([cx + a.r * np.sin(psi), cz - a.r * np.cos(psi), lp.floor_angle(a.alpha, turn, a.r, floor)], 1)
    ex, ez = arc[-1, 0], arc[-1, 1]
    top = max(float(terrain.surface(ex)) + rules.lift_clearance, ez) + lift_extra
    zl = np.arange(ez + step, top + 1e-9, step)
    lift = np.stack([np.full(zl.size, ex), zl, np.full(zl.size, arc[-1, 2])], axis=1)
    poses = np.concatenate([line, arc, lift])
    phase = np.concatenate(phase + [np.ones(len(arc), int), np.full(len(lift), 2)])
    return poses, phase


def joint_path(machine, poses: np.ndarray, base_x: float) -> tuple[np.ndarray, slice]:
    """The MJCF joint values (M, n) of tip poses (N, 3): the loader's (d1, theta2, theta3), the shovel's
    (base x, theta1, theta2, theta3), and which poses they are (a slice): unreachable poses at the start (the
    pre-entry) and at the end (the lift above the planner's clearance) are dropped; a gap in between raises.

    Raises:
        ExcavsimError: no pose, or one between two reachable ones, is out of reach.
    """
    if machine.moves_base:
        q, ok = machine.inverse(poses)
    else:
        q, ok = machine.inverse(poses, base_x)
        q = np.concatenate([np.full((len(q), 1), base_x), q], axis=1)
    idx = np.flatnonzero(ok)
    if idx.size == 0 or not ok[idx[0]:idx[-1] + 1].all():
        bad = len(ok) - idx.size if idx.size == 0 else int((~ok[idx[0]:idx[-1] + 1]).sum())
        raise GoalError(f"{bad} poses of the planned dig are out of the machine's reach")
    kept = slice(int(idx[0]), int(idx[-1]) + 1)
    return q[kept], kept


# ---------------------------------------------------------------------------------------------- the episode
class LoadTask:
    """Loading from a pile in MuJoCo as a task of the platform's :class:`~excavsim.loop.episode.Episode`
    (see the module docstring): the world is a :class:`~excavsim.tasks.pile_loading.world.scene.LoadingWorld` with
    the pile written into its lane; each cycle scans, plans on the map's sections (the done test: no dig
    of minimal utility on any section), executes the dig, the dump and the return by script, and settles;
    the result is a :class:`MujocoRun` (its ``end``: ``done`` when the planner finds no dig of minimal
    utility on the map, ``no_dig`` when a planned pose is out of reach, ``budget``, ``diverged``). The observers' hooks get (world, machine name) at the start, the
    map and the planned section's terrain per scan, the plan and the dig's tip path per plan, and the
    :class:`MujocoDig` per dig. Without a final scan: the episode ends right after its last dig.

    Args:
        name: ``loader`` or ``shovel``.
        cfg, cfg2d, pile, world_hooks, account: as :func:`run_loading_episode`'s.
    """

    final_scan = False
    wall_limit_s = math.inf

    def __init__(self, name: str, *, cfg: LoadingMujocoConfig | None = None, cfg2d: ld.LoadingConfig | None = None,
                 pile: PileLane | None = None, world_hooks=(), account: SoilAccount | None = None):
        if name not in MACHINES:
            raise ConfigError(f"unknown loading machine {name!r}; allowed: {', '.join(MACHINES)}")
        self.name = name
        self.cfg = cfg or load_mujoco_config()
        self.cfg2d = cfg2d or ld.load_loading_config()
        self.pile, self.world_hooks, self._account = pile, tuple(world_hooks), account

    def reset(self, seed: int, world: LoadingWorld | None = None, digs=None) -> tuple:
        if digs is not None:
            raise UsageError("a loading episode takes its digs from the loading planner; no dig source can be "
                             "given (digs must be None)")
        cfg, cfg2d, name = self.cfg, self.cfg2d, self.name
        world = world if world is not None else LoadingWorld(name, soil=cfg.soil, seed=seed)
        world.set_terrain(world.section_heights(*pile_section(world, self.pile or cfg.pile)))
        self.world = world
        self.account = account = self._account if self._account is not None else SoilAccount()
        account.reset(world)
        world.step_hooks.append(account)
        world.step_hooks.extend(self.world_hooks)
        self.scanner = make_scanner(world, cfg, seed)
        self.machine = ld.make_machine(cfg2d, name)
        spec = getattr(cfg2d.machines, name)
        self.rules = ld.make_rules(cfg2d, spec.capacity_units)
        mscript = getattr(cfg.script, name)
        self.speed, self.tol = np.array(mscript.joint_speed), np.array(mscript.tolerance)
        self.start = world.volumes().box
        self.digs: list[MujocoDig] = []
        self.q = world.joint_angles()
        self.trace: list[np.ndarray] = []
        self.forces: list[float] = []
        world.step_hooks.append(self._witness)
        self.map_first = self.map_end = math.nan
        return world, name

    def _witness(self, w: LoadingWorld) -> None:
        self.trace.append(w.tip_pose())
        self.forces.append(float(np.linalg.norm(w.contact.force)))

    def _play(self, script: ls.JointScript, results: list) -> None:
        res, self.q = ls.play_script(self.world.step, self.q, script, self.world.control_dt, tolerance=self.tol)
        results.append(res)

    def budget_reason(self, budget: int) -> str:
        return f"{budget} digs spent"

    def park(self) -> None:
        """Nothing: the machine scans from where the last cycle left it (carry)."""

    def scan(self) -> tuple[ElevationMap, lp.PileSection]:
        cfg, world = self.cfg, self.world
        emap, _ = scan_map(self.scanner, world.time, load_sensing_config().map, cfg.n_scans)
        self.map_end = map_soil_m3(emap, world.width, self.rules.ground)
        self.map_first = self.map_end if not self.digs else self.map_first
        self.section, self.terrain, self.plan = choose_section(self.machine, map_sections(emap, cfg.section_half_width),
                                                               self.rules)
        return emap, self.terrain

    def assess(self, index, scanned, say):
        if self.plan.action is None:
            map_end, map_first = self.map_end, self.map_first
            share = f" ({100 * map_end / map_first:.1f} % of the first map)" if map_first > 0 else ""
            return scanned, ("done", f"{self.plan.reason}; the map shows {map_end:.3f} m^3 more than "
                                       f"{100 * self.rules.ground:.0f} cm above the ground{share}")
        return scanned, None

    def choose(self, emap) -> Choice:
        plan, sc, machine = self.plan, self.cfg.script, self.machine
        poses, _ = dig_poses(plan.action, self.terrain, self.rules, machine.floor, step=sc.path_step,
                             lift_extra=sc.lift_extra)
        try:
            self.qp, _ = joint_path(machine, poses, plan.base_x)
        except ExcavsimError as exc:  # a planned pose the machine's IK cannot reach: said, never executed blindly
            return Choice(None, f"dig {len(self.digs) + 1} not executed: {exc}")
        return Choice(poses, plan=plan)

    def execute(self, index, choice):
        world, account, machine, sc = self.world, self.account, self.machine, self.cfg.script
        plan, qp, poses, speed, play = self.plan, self.qp, choice.dig, self.speed, self._play
        dt = world.control_dt
        carry, dump = world.keyframes["carry"], world.keyframes["dump"]
        try:
            self.trace.clear()
            self.forces.clear()
            results: list[ls.ScriptResult] = []
            delivered0, spilled0 = account.delivered, account.spilled
            # to the dig: the loader sets its arm and drives in; the shovel drives its base, then sets its arm
            q = self.q
            if machine.moves_base:
                staged = np.r_[q[0], qp[0, 1:]]
            else:
                staged = np.r_[qp[0, 0], q[1:]]
            play(ls.joint_move(self.q, staged, joint_speed=speed, name="arm to the dig" if machine.moves_base
                               else "base to its place"), results)
            play(ls.joint_move(self.q, qp[0], joint_speed=speed, name="to the pre-entry pose"), results)
            play(ls.timed_path(qp, np.array([machine_tip(machine, qq) for qq in qp]), tip_speed=sc.tip_speed,
                               joint_speed=speed, name="dig"), results)
            tip_path = np.array(self.trace)
            peak = max(self.forces, default=0.0)
            bucket = world.volumes().bucket
            back = self.q.copy()
            back[0] += sc.back_off if machine.moves_base else -sc.back_off  # the loader's d1 grows backwards
            play(ls.joint_move(self.q, back, joint_speed=speed, name="back off"), results)
            play(ls.joint_move(self.q, carry, joint_speed=speed, name="carry"), results)
            account.dumping = True  # the bucket over the truck: what pours out of the lane now is delivered
            try:
                play(ls.joint_move(self.q, dump, joint_speed=speed, name="dump"), results)
                for _ in range(int(sc.dump_hold_s / dt)):
                    self.q = world.step(dump)
            finally:
                account.dumping = False
            play(ls.joint_move(self.q, carry, joint_speed=speed, name="back to carry"), results)
            world.settle_soil()
            v = world.volumes()
            dig = MujocoDig(plan.action, plan.base_x, plan.volume * world.width, bucket,
                            account.delivered - delivered0, account.spilled - spilled0, v.box, results, tip_path,
                            poses, peak, self.section)
            self.digs.append(dig)
        except Diverged as exc:  # an outcome, never a hang: the episode ends and says why
            return None, ("diverged", f"dig {index}: {exc}")
        return (dig,), None

    def after(self, index, choice, dug, say):
        dig, = dug
        a = dig.action
        say(f"  dig {index:3d} ({dig.section}): k {a.k:5.2f} m, alpha {math.degrees(a.alpha):5.1f} deg, d1 "
            f"{a.d1:4.2f} m, r {a.r:4.2f} m: planned {dig.planned_m3:.3f} m^3, bucket {dig.bucket_m3:.3f}, "
            f"delivered {dig.delivered_m3:.3f}, spilled {dig.spilled_m3:.3f}, lane {dig.lane_m3:.3f} m^3, "
            f"peak soil force {dig.peak_force_n / 1000:.1f} kN")
        return None

    def result(self, end, reason, wall_s) -> MujocoRun:
        world, account = self.world, self.account
        v = world.volumes()
        drift = v.box + v.bucket + account.delivered + account.spilled - world.soil.initial_volume
        return MujocoRun(self.name, world.soil.heaped_capacity, world.width, self.digs, reason, self.start, v.box,
                         drift, self.cfg.tolerance_fraction, world.time, self.map_end, end, wall_s)


def run_loading_episode(name: str, *, seed: int = 0, cfg: LoadingMujocoConfig | None = None,
                        cfg2d: ld.LoadingConfig | None = None, pile: PileLane | None = None,
                        max_digs: int | None = None, observer: LoadingObserver | None = None, progress=None,
                        world_hooks=(),
                        account: SoilAccount | None = None) -> MujocoRun:
    """One loading episode of ``name`` (``loader`` or ``shovel``) in MuJoCo (see the module docstring): the
    platform's :class:`~excavsim.loop.episode.Episode` of a :class:`LoadTask`, cycled to its end.

    Args:
        seed: the episode seed (the soil's heterogeneity, the scanner's noise and drift).
        cfg, cfg2d: the MuJoCo and the 2-D loading configurations (the files' when None); the machine's
            kinematics, capacity and the planner's grid come from ``cfg2d``.
        pile: a pile other than the configuration's; max_digs: a limit other than the configuration's.
        observer: sees the episode's hooks (:class:`LoadingObserver`; dig indices from 1).
        world_hooks: callables run after every control step with the world (tests: the volume account).
        account: the delivered/spilled account to keep (a new one when None; tests read it at every step).
    """
    task = LoadTask(name, cfg=cfg, cfg2d=cfg2d, pile=pile, world_hooks=world_hooks, account=account)
    episode = Episode(task, dig_budget=max_digs or task.cfg.max_digs, progress=progress, observer=observer)
    episode.reset(seed)
    return episode.run()


def machine_tip(machine, q: np.ndarray) -> np.ndarray:
    """The tip (x, z) of MJCF joint values ``q`` by the machine's closed form."""
    if machine.moves_base:
        return machine.forward(q)[:2]
    return machine.forward(q[1:], q[0])[:2]


def episode_recorder(path: str | None, *, live: str | None = None):
    """The Rerun recorder of a loading episode to ``path`` and/or streamed to the viewer at ``live`` (a gRPC
    URL): the lane, the scanned maps, the planned digs and the machine's motion, per dig."""
    from excavsim.tasks.pile_loading.recording import LoadingRecorder

    return LoadingRecorder(path, live=live)


def format_run(run: MujocoRun) -> str:
    """A MuJoCo episode's digs as a table [m^3] and its end."""
    lines = [f"{'dig':>4} {'k m':>5} {'h m':>5} {'alpha':>6} {'d1 m':>5} {'r m':>5} {'base x':>7} {'planned':>8} "
             f"{'bucket':>7} {'deliv.':>7} {'spilled':>7} {'lane':>7} {'peak kN':>8} section"]
    for i, d in enumerate(run.digs, 1):
        a = d.action
        bx = "moving" if not math.isfinite(d.base_x) else f"{d.base_x:7.2f}"
        lines.append(f"{i:4d} {a.k:5.2f} {a.h:5.2f} {math.degrees(a.alpha):6.1f} {a.d1:5.2f} {a.r:5.2f} {bx:>7} "
                     f"{d.planned_m3:8.3f} {d.bucket_m3:7.3f} {d.delivered_m3:7.3f} {d.spilled_m3:7.3f} "
                     f"{d.lane_m3:7.3f} {d.peak_force_n / 1000:8.1f} {d.section}")
    lines.append(f"end: {run.reason}; lane {run.start_m3:.3f} -> {run.end_m3:.3f} m^3 "
                 f"({100 * run.removed_fraction:.1f} % removed, {'within' if run.done else 'NOT within'} the "
                 f"{100 * run.tolerance_fraction:.0f} % tolerance); {len(run.digs)} digs, "
                 f"{run.per_dig():.3f} m^3 delivered per dig = {100 * run.efficiency():.0f} % of the heaped "
                 f"capacity {run.capacity_m3:.3f} m^3; {run.spilled_m3:.3f} m^3 spilled off the lane; volume account "
                 f"drift {run.total_drift_m3:.1e} m^3; {run.sim_time_s:.0f} s simulated")
    return "\n".join(lines)


# -- what the platform's specification and campaigns ask of a task (excavsim.loop.scenario) ----------

def summary(run: MujocoRun) -> dict[str, Any]:
    """A loading episode's metrics (a :class:`MujocoRun`) as the flat dict of
    :func:`~excavsim.loop.scenario.episode_summary`: the same keys where they mean the same (``end``,
    ``reason``, ``digs``, ``removed_fraction`` of the pile, ``dug_l_per_dig`` in the bucket at lift-out, ``planned_l_per_dig``,
    ``efficiency``: delivered per dig over the heaped capacity, ``sim_s``, ``wall_s``,
    ``volume_change_m3``: the volume account's drift), and the loading's own (delivered, spilled, the
    lane's soil and the map's at the end, the peak soil force; ``failed_digs``: digs that delivered under a
    tenth of the heaped capacity, assumed)."""
    digs = run.digs
    n = len(digs)
    out: dict[str, Any] = {
        "task": "pile_loading", "machine": run.machine, "end": run.end, "reason": run.reason, "digs": n,
        "removed_fraction": run.removed_fraction, "pile_removed": bool(run.done),
        "failed_digs": sum(d.delivered_m3 < 0.1 * run.capacity_m3 for d in digs),
        "dug_l_per_dig": 1000 * sum(d.bucket_m3 for d in digs) / n if n else 0.0,
        "planned_l_per_dig": 1000 * sum(d.planned_m3 for d in digs) / n if n else 0.0,
        "efficiency": run.efficiency() if n else 0.0,
        "delivered_l": 1000 * run.delivered_m3, "spilled_l": 1000 * run.spilled_m3,
        "start_l": 1000 * run.start_m3, "end_l": 1000 * run.end_m3, "map_end_l": 1000 * run.map_end_m3,
        "peak_force_kn": max((d.peak_force_n for d in digs), default=0.0) / 1000,
        "sim_s": run.sim_time_s, "wall_s": run.wall_time_s, "volume_change_m3": run.total_drift_m3,
    }
    out["dug_l"] = [round(1000 * d.bucket_m3, 3) for d in digs]
    return out


def dig_rows(res: MujocoRun) -> list[dict[str, Any]]:
    """One JSON-ready row per dig of a loading episode: its action, section and volumes [l] and its peak
    soil force [kN] (:func:`~excavsim.loop.scenario.dig_rows`)."""
    return [{"dig": i, "section": d.section, "k_m": d.action.k, "h_m": d.action.h,
             "alpha_deg": math.degrees(d.action.alpha), "d1_m": d.action.d1, "r_m": d.action.r,
             "base_x_m": d.base_x, "planned_l": 1000 * d.planned_m3, "dug_l": 1000 * d.bucket_m3,
             "delivered_l": 1000 * d.delivered_m3, "spilled_l": 1000 * d.spilled_m3,
             "lane_l": 1000 * d.lane_m3, "peak_force_kn": d.peak_force_n / 1000}
            for i, d in enumerate(res.digs, start=1)]
