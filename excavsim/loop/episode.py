"""The episode driver: the dig-scan-plan loop repeated until the trench is done (§7.2, Fig. 107).

:class:`Episode` is the one loop of excavsim. Each cycle parks the arm, scans the box into an
elevation map, asks a :class:`~excavsim.loop.digs.DigSource` for one dig on the map (by default the
planner, falling back to the boundary-following digs of §7.2), executes it with the dig script and
lets the soil settle. The episode ends when the trench meets its tolerance on the map (at least
``done_fraction`` of the goal volume removed and no cell more than ``tolerance_m`` above the goal
profile), when the source has no dig, when the dig budget is spent, when the simulation diverged
(``diverged``: the world's watchdog saw a MuJoCo warning, a reset or a non-finite state; the dig
that saw it has outcome ``diverged``, and the world cannot be stepped any more), or when the
executor's ``episode_wall_limit_s`` of wall time has passed (``timeout``). Metrics per dig and per
episode: soil per dig (predicted, in the bucket), efficiency (bucket / capacity), over- and
under-dig against the goal on the true terrain, stalls, planning and simulated time, peak and
cumulative torques, and why the episode ended.

:class:`Episode` is the episode as an object one can reset and advance one cycle (or one phase of
a cycle) at a time; :func:`run_episode` cycles one to its end, and the dig-level environments
(:mod:`excavsim.envs`) step one with the agent's digs. ``excavsim trench`` runs it; ``excavsim
cycle`` is an episode of one dig, ``excavsim demo`` one of a scripted dig, and ``excavsim learn`` collects force data with an episode of random feasible digs.
An :class:`~excavsim.handoff.episode.EpisodeObserver` handed in by the caller (the Rerun recorder,
the online learner) sees every scan, plan, control step and dig.
"""

from __future__ import annotations

import contextlib
import math
import pathlib
import time
from collections.abc import Callable
from typing import Any, Protocol

import numpy as np

from excavsim.config import ExecutorConfig, PlannerConfig, RobotConfig, SceneConfig, SensingConfig, TrenchGoal
from excavsim.errors import ExcavsimError
from excavsim.handoff.dig import Dig, DigPlan, ExecutionRecord
from excavsim.handoff.episode import DigMetrics, EpisodeObserver, EpisodeResult
from excavsim.handoff.goal import goal_profile
from excavsim.handoff.maps import ElevationMap
from excavsim.handoff.observation import Diverged, OutOfTime
from excavsim.loop.digs import Choice, DigSource, PlannedDigs
from excavsim.loop.rig import bucket_witness, go_home, make_rig, park, scan
from excavsim.mechanics.wedge import G_M_S2
from excavsim.planning.experience import DigExperience, failure_kind
from excavsim.robot.kinematics import PlanarArm
from excavsim.world.simulation import Simulation

MIN_USEFUL_M3 = 0.001  # a dig that brings up less than 1 l failed (the measure campaigns report)


class EpisodeError(ExcavsimError):
    """An episode's phase called out of order: before :meth:`Episode.reset`, after its end, or
    skipping a phase (look, decide, dig)."""


class MapWriter(EpisodeObserver):
    """Saves every scanned elevation map as ``DIR/map_<cycle>.npz`` (for ``excavsim plan --map``)."""

    def __init__(self, directory: str | pathlib.Path):
        self.directory = pathlib.Path(directory)
        self.paths: list[pathlib.Path] = []

    def started(self, sim, rig, goal_mask, goal_z):
        self.directory.mkdir(parents=True, exist_ok=True)

    def scanned(self, index, emap, accuracy):
        path = self.directory / f"map_{index:02d}.npz"
        emap.save(path)
        self.paths.append(path)


def trench_footprint(sim: Simulation, goal: TrenchGoal, width: float) -> tuple[np.ndarray, np.ndarray]:
    """Grid samples inside the trench's footprint (mask) and the goal profile height at each sample."""
    g = sim.soil.grid
    xs, ys = np.meshgrid(g.x0 + np.arange(g.shape[1]) * g.cell, g.y0 + np.arange(g.shape[0]) * g.cell)
    w = math.radians(goal.waist_deg)
    radial = xs * math.cos(w) + ys * math.sin(w)
    lateral = -xs * math.sin(w) + ys * math.cos(w)
    mask = (np.abs(lateral) <= width / 2) & (radial >= goal.near_x_m) & (radial <= goal.far_x_m)
    return mask, goal_profile(goal, radial)


def map_done(emap: ElevationMap, goal: TrenchGoal, arm: PlanarArm, width: float, *, done_fraction: float,
             tolerance_m: float, initial_z: float) -> tuple[bool, float]:
    """Whether the trench meets its tolerance on the scanned map, and the removed fraction there."""
    x = np.linspace(goal.near_x_m, goal.far_x_m, 60)
    pts = arm.plane_to_world(math.radians(goal.waist_deg), np.stack([x, np.zeros_like(x)], axis=-1))
    z = emap.height_at(pts[:, 0], pts[:, 1])
    zg = goal_profile(goal, x)
    target = np.clip(initial_z - zg, 0, None).sum()
    removed = np.clip(initial_z - z, 0, None).clip(max=initial_z - zg).sum()
    frac = float(removed / target) if target > 0 else 1.0
    return bool(frac >= done_fraction and np.max(z - zg) <= tolerance_m), frac


class Task(Protocol):
    """What a task supplies to the platform's :class:`Episode`: its world and pieces, its map reading,
    its dig source, its execution of a dig, its done test and its metrics. The episode does the rest,
    written once for every task: the order of the phases, the observers' hooks, the dig budget,
    the wall clock and its limit, the world's failures while parking, and the end.

    Each hook's arguments are the task's own (a trench's :class:`~excavsim.handoff.dig.Dig` and
    :class:`~excavsim.handoff.dig.ExecutionRecord`, a loading dig's path and its
    :class:`~excavsim.tasks.load.in_mujoco.MujocoDig`); an observer of a task knows them.

    Attributes:
        wall_limit_s: the episode's wall-clock limit [s] (``math.inf``: none), known after :meth:`reset`.
        final_scan: whether the dig budget's last dig is followed by a scan that checks it (a
            trench's done test); otherwise the episode ends right after it.
    """

    wall_limit_s: float
    final_scan: bool

    def reset(self, seed: int, world: Any = None, digs: Any = None) -> tuple:
        """Build the world (unless given) and the task's pieces for an episode of ``seed``; the
        arguments of the observers' ``started`` hook (the world first)."""

    def budget_reason(self, budget: int) -> str:
        """Why the episode ended when its ``budget`` of digs was spent."""

    def park(self) -> None:
        """The moves before a scan (may raise ``Diverged`` or ``OutOfTime``: the episode ends)."""

    def scan(self) -> tuple[ElevationMap, Any]:
        """Scan the terrain into a map: the map and the ``scanned`` hook's detail."""

    def assess(self, index: int, scanned: ElevationMap, say: Callable[[str], None]
               ) -> tuple[Any, tuple[str, str] | None]:
        """The map the dig source believes, and (end, reason) when the map ends the episode (done)."""

    def choose(self, emap: Any) -> Choice:
        """The cycle's dig on the believed map (a :class:`~excavsim.loop.digs.Choice`; no dig ends the episode)."""

    def execute(self, index: int, choice: Choice) -> tuple[tuple | None, tuple[str, str] | None]:
        """Execute dig ``index`` and let the soil settle: the ``dug`` hook's arguments after the index,
        or None and (end, reason) when the world failed before there was a dig to record."""

    def after(self, index: int, choice: Choice, dug: tuple, say: Callable[[str], None]) -> tuple[str, str] | None:
        """After the ``dug`` hook: report, learn, and (end, reason) when the dig ended the episode."""

    def result(self, end: str, reason: str, wall_s: float) -> Any:
        """The episode's result (the ``finished`` hook's argument)."""


class TrenchTask:
    """Trenching (§7.2, Fig. 107): the T3 digs a trench goal out of its soil box.

    Its world is a :class:`~excavsim.world.simulation.Simulation`, its pieces the loop's
    :class:`~excavsim.loop.rig.Rig`; it parks the arm out of the scanner's view before each scan,
    is done when the map shows the trench within tolerance, takes its digs from a
    :class:`~excavsim.loop.digs.DigSource` (the planner by default), executes them with the dig
    script and measures them (:class:`~excavsim.handoff.episode.DigMetrics`); its result is an
    :class:`~excavsim.handoff.episode.EpisodeResult`. Arguments as :class:`Episode`'s.
    """

    final_scan = True

    def __init__(self, *, goal: TrenchGoal | None = None, done_fraction: float | None = 0.95,
                 tolerance_m: float = 0.03, planner_cfg: PlannerConfig | None = None,
                 executor_cfg: ExecutorConfig | None = None, sensing_cfg: SensingConfig | None = None,
                 robot_cfg: RobotConfig | None = None, scene_cfg: SceneConfig | None = None):
        self.goal, self.done_fraction, self.tolerance_m = goal, done_fraction, tolerance_m
        self.planner_cfg, self.executor_cfg, self.sensing_cfg = planner_cfg, executor_cfg, sensing_cfg
        self.robot_cfg, self.scene_cfg = robot_cfg, scene_cfg
        self.wall_limit_s = math.inf

    def reset(self, seed: int, world: Simulation | None = None, digs: DigSource | None = None) -> tuple:
        sim = world if world is not None else Simulation(self.robot_cfg, self.scene_cfg, seed=seed)
        self.sim = sim
        self.source = digs or PlannedDigs(DigExperience())
        self.rig = rig = make_rig(sim, seed=seed, goal=self.goal, planner_cfg=self.planner_cfg,
                                  executor_cfg=self.executor_cfg, sensing_cfg=self.sensing_cfg)
        self.wall_limit_s = rig.executor_cfg.episode_wall_limit_s
        self.mask, self.z_goal = trench_footprint(sim, rig.goal, rig.width)
        self._h0 = sim.soil.grid.heights.copy()
        self._v0 = sim.soil.initial_volume
        self.metrics: list[DigMetrics] = []
        self.record: ExecutionRecord | None = None  # the last dig's
        self.emap: ElevationMap | None = None  # the map the source believes, this cycle
        self.accuracy = None
        self._witness = bucket_witness(sim)
        return sim, rig, self.mask, self.z_goal

    def budget_reason(self, budget: int) -> str:
        return f"dig budget of {budget} spent"

    def park(self) -> None:
        park(self.sim, self.rig)

    def scan(self) -> tuple[ElevationMap, Any]:
        scanned, self.accuracy = scan(self.sim, self.rig)
        return scanned, self.accuracy

    def assess(self, index, scanned, say):
        rig, goal, fraction = self.rig, self.rig.goal, self.done_fraction
        self.emap = emap = self.source.belief(rig, scanned)  # the scanned map, as the executed digs corrected it
        done, frac = map_done(emap, goal, rig.arm, rig.width, tolerance_m=self.tolerance_m,
                              initial_z=goal.surface_z_m, done_fraction=1.0 if fraction is None else fraction)
        say(f"dig {index}: map {100 * frac:.0f} % of the goal removed (map RMS {100 * self.accuracy.rms_m:.1f} cm)")
        if done and fraction is not None:
            return emap, ("done", f"trench done on the map: {100 * frac:.0f} % removed, every cell within "
                                  f"{100 * self.tolerance_m:.0f} cm")
        return emap, None

    def choose(self, emap) -> Choice:
        return self.source.choose(self.rig, emap)

    def execute(self, index, choice):
        sim, rig, goal, dig = self.sim, self.rig, self.rig.goal, choice.dig
        try:
            go_home(sim, rig)
        except (Diverged, OutOfTime) as exc:
            return None, _world_failed(exc, f"going home for dig {index}")
        t0 = sim.time
        clearance = float(np.min(dig.poses[:, 1] - goal_profile(goal, dig.poses[:, 0])))
        bounds = (-max(clearance, 0.0), math.inf if dig.shift_up else 0.0)
        plan = DigPlan(dig.poses, dig.phases, math.radians(goal.waist_deg), dig.volume_m3, bounds,
                       surface=rig.planner.surface(self.emap))
        self.record = rec = rig.executor.run(plan, on_phase=self._witness)
        sim.settle_soil()
        metrics = dig_metrics(index, dig, rec, capacity=rig.capacity, sim_s=float(sim.time - t0),
                              ft_rate_hz=rig.executor.ft.rate_hz, density_kg_m3=rig.planner.density)
        self.metrics.append(metrics)
        return (rec, metrics), None

    def after(self, index, choice, dug, say):
        rec, metrics = dug
        dig = choice.dig
        say(f"  {dig.kind} {rec.outcome}: {1000 * dig.volume_m3:.1f} l planned, "
            f"{1000 * rec.bucket_volume_m3:.1f} l dug" + (f", stall at {metrics.stall_joint}" if metrics.stall_joint else ""))
        if rec.outcome == "diverged" or rec.outcome.startswith("timeout: "):  # the world cannot go on
            why = rec.warnings[-1] if rec.outcome == "diverged" else rec.outcome[len("timeout: "):]
            return ("diverged" if rec.outcome == "diverged" else "timeout"), f"{why} (dig {index})"
        lesson = self.source.learned(self.rig, index, dig, rec, self.emap)
        if lesson:
            say(lesson)
        return None

    def result(self, end, reason, wall_s) -> EpisodeResult:
        return episode_result(self.sim, self.metrics, end, reason, mask=self.mask, z_goal=self.z_goal,
                              h0=self._h0, v0=self._v0, wall_s=wall_s)


class Episode:
    """An episode of a :class:`Task` (trenching by default) as an object: :meth:`reset` it, then
    advance it one cycle at a time.

    A cycle (:meth:`step`) is three phases, which a caller that decides the dig itself (the
    environments of :mod:`excavsim.envs`) may call one by one:

    * :meth:`look`: the task parks, scans the terrain into a map (the ``scanned`` hook) and reads
      it (the dig source's belief; the done test); the wall clock's and the dig budget's limits;
    * :meth:`decide`: the cycle's dig, from the task's dig source or given by the caller (the
      ``planned`` hook); no dig ends the episode (``no_dig``);
    * :meth:`dig`: the task executes the dig and lets the soil settle (the ``dug`` hook), then
      reports and learns.

    The episode ends (:attr:`over`; :attr:`result` set, the ``finished`` hook called) when a phase
    meets a stopping rule; an error in a phase ends it too (``finished`` with None), and
    :meth:`close` abandons a running one the same way. The wall clock runs only inside the phases,
    so the time a caller spends between them (an agent thinking) counts neither towards the task's
    wall-clock limit nor towards the result's wall time.

    Args:
        task: the task (default: a :class:`TrenchTask` of the arguments below).
        dig_budget: the most digs.
        goal, done_fraction, tolerance_m, planner_cfg, executor_cfg, sensing_cfg, robot_cfg, scene_cfg:
            the default trenching task's (see :class:`TrenchTask`): the trench (default
            ``configs/trenches/straight.yaml``); the trench is done on the map when ``done_fraction``
            of the goal volume is removed and no cell is more than ``tolerance_m`` above the goal
            profile (None never stops early: digging for data); configurations (default
            ``configs/``), the world's used when :meth:`reset` is given none.
        progress: called with a line of text per scan and per dig.
        observer: sees every episode (see :class:`~excavsim.handoff.episode.EpisodeObserver`).
    """

    def __init__(self, task: Task | None = None, *, goal: TrenchGoal | None = None, dig_budget: int = 20,
                 done_fraction: float | None = 0.95, tolerance_m: float = 0.03,
                 planner_cfg: PlannerConfig | None = None, executor_cfg: ExecutorConfig | None = None,
                 sensing_cfg: SensingConfig | None = None, robot_cfg: RobotConfig | None = None,
                 scene_cfg: SceneConfig | None = None, progress: Callable[[str], None] | None = None,
                 observer: EpisodeObserver | None = None):
        if task is None:
            task = TrenchTask(goal=goal, done_fraction=done_fraction, tolerance_m=tolerance_m,
                              planner_cfg=planner_cfg, executor_cfg=executor_cfg, sensing_cfg=sensing_cfg,
                              robot_cfg=robot_cfg, scene_cfg=scene_cfg)
        self.task = task
        self.dig_budget = int(dig_budget)
        self.say = progress or (lambda _s: None)
        self.observer = observer or _Unobserved()
        self.sim = None  # the world
        self.over = True  # no episode runs before reset
        self.result = None
        self._phase = "none"
        self._hooked = False

    # -- the episode ---------------------------------------------------------------------------------
    def reset(self, seed: int = 0, *, sim=None, digs=None) -> None:
        """Start an episode with ``seed`` (abandoning a running one, see :meth:`close`).

        Args:
            seed: the episode seed (the scanner's noise and drift; the soil's too when the world is built here).
            sim: the world, as built (default: the task builds one with ``seed``).
            digs: where each cycle's dig comes from (default: the task's; for trenching
                :class:`~excavsim.loop.digs.PlannedDigs` with a fresh
                :class:`~excavsim.planning.experience.DigExperience`).
        """
        self.close()
        self._wall_s = 0.0
        self._t0 = time.perf_counter()
        self.seed = seed
        started = self.task.reset(seed, sim, digs)
        self.sim = started[0]
        self.digs_done = 0
        self.emap = None  # the map the dig source believes, this cycle
        self.choice: Choice | None = None
        self.dug: tuple | None = None  # the last dig's ``dug`` hook arguments after the index
        self.result = None
        self.end, self.reason = "budget", self.task.budget_reason(self.dig_budget)
        self.observer.started(*started)
        self.sim.step_hooks.append(self.observer.stepped)
        self._hooked = True
        self.over = False
        self._phase = "look"
        self._wall_s += time.perf_counter() - self._t0

    @property
    def index(self) -> int:
        """The cycle's number, 1-based: the digs done so far plus one."""
        return self.digs_done + 1

    def step(self) -> None:
        """One cycle: :meth:`look`, :meth:`decide` (the dig source's dig), :meth:`dig`, as far as the episode goes."""
        self.look()
        if not self.over:
            self.decide()
        if not self.over:
            self.dig()

    def run(self):
        """Cycle until the episode ends; its result."""
        while not self.over:
            self.step()
        return self.result

    # -- the phases ----------------------------------------------------------------------------------
    def look(self):
        """Park, scan and test the stopping rules; the map the dig source believes (None when the episode ended)."""
        with self._clock("look"):
            i, task = self.digs_done, self.task
            if self._elapsed() > task.wall_limit_s:
                return self._end("timeout", f"the episode's wall-clock limit of {task.wall_limit_s:g} s passed "
                                            f"after {i} digs")
            try:
                task.park()
            except (Diverged, OutOfTime) as exc:  # in the moves between digs: no dig to record
                return self._end(*_world_failed(exc, f"parking after {i} digs"))
            scanned, detail = task.scan()
            self.observer.scanned(i + 1, scanned, detail)
            self.emap, stop = task.assess(i + 1, scanned, self.say)
            if stop is not None:
                return self._end(*stop)
            if i == self.dig_budget:  # the last scan only checks whether the budget's digs finished the task
                return self._end(self.end, self.reason)
            self._phase = "decide"
            return self.emap

    def decide(self, choice: Choice | None = None) -> Choice:
        """The cycle's dig: ``choice``, or the task's dig source's on the believed map; no dig ends the episode."""
        with self._clock("decide"):
            if choice is None:
                choice = self.task.choose(self.emap)
            self.choice = choice
            if choice.plan is not None or choice.dig is not None:
                self.observer.planned(self.index, choice.plan, choice.dig)
            if choice.dig is None:
                self._end("no_dig", choice.reason)
                return choice
            if choice.note:
                self.say(choice.note)
            self._phase = "dig"
            return choice

    def dig(self) -> tuple | None:
        """Execute the decided dig and let the soil settle; the ``dug`` hook's arguments after the index
        (for trenching the execution record and the dig's metrics), None when the world failed on the way."""
        with self._clock("dig"):
            i, task = self.index, self.task
            dug, stop = task.execute(i, self.choice)
            if dug is None:
                self._end(*stop)
                return None
            self.digs_done += 1
            self.dug = dug
            self.observer.dug(i, *dug)
            stop = task.after(i, self.choice, dug, self.say)
            if stop is not None:
                self._end(*stop)
            elif not task.final_scan and self.digs_done == self.dig_budget:
                self._end(self.end, self.reason)
            else:
                self._phase = "look"
            return dug

    def close(self) -> None:
        """Abandon a running episode: its observers hear ``finished(None)``; the world is left as it is."""
        if not self.over:
            self._unhook()
            self.over = True
            self._phase = "none"
            self.observer.finished(None)

    # -- inside ----------------------------------------------------------------------------------------
    @contextlib.contextmanager
    def _clock(self, phase: str):
        """Run a phase: in order, on the wall clock, with the world's wall deadline set; an error ends the episode."""
        if self._phase != phase:
            raise EpisodeError(f"the episode cannot {phase} now: "
                               + ("it has ended (or never started); call reset() first" if self.over
                                  else f"the next phase is {self._phase}"))
        self._t0 = time.perf_counter()
        if hasattr(self.sim, "wall_deadline"):
            self.sim.wall_deadline = self._t0 + self.task.wall_limit_s - self._wall_s
        try:
            yield
        except BaseException:
            self.close()
            raise
        finally:
            if hasattr(self.sim, "wall_deadline"):
                self.sim.wall_deadline = None
            self._wall_s += time.perf_counter() - self._t0

    def _elapsed(self) -> float:
        """Wall time of the episode so far [s] (inside its phases)."""
        return self._wall_s + time.perf_counter() - self._t0

    def _end(self, end: str, reason: str) -> None:
        """End the episode: the task's result, then ``finished``."""
        self.end, self.reason = end, reason
        self.result = self.task.result(end, reason, self._elapsed())
        self._unhook()
        self.over = True
        self._phase = "none"
        self.observer.finished(self.result)

    def _unhook(self) -> None:
        if hasattr(self.sim, "wall_deadline"):
            self.sim.wall_deadline = None
        if self._hooked:
            self.sim.step_hooks.remove(self.observer.stepped)
            self._hooked = False


class _Unobserved:
    """No observer: every hook, with any task's arguments, does nothing."""

    def started(self, *args) -> None: ...
    def scanned(self, *args) -> None: ...
    def planned(self, *args) -> None: ...
    def stepped(self, *args) -> None: ...
    def dug(self, *args) -> None: ...
    def finished(self, *args) -> None: ...


def run_episode(sim: Simulation, *, seed: int = 0, goal: TrenchGoal | None = None, dig_budget: int = 20,
                done_fraction: float | None = 0.95, tolerance_m: float = 0.03,
                planner_cfg: PlannerConfig | None = None, executor_cfg: ExecutorConfig | None = None,
                sensing_cfg: SensingConfig | None = None, digs: DigSource | None = None,
                progress: Callable[[str], None] | None = None,
                observer: EpisodeObserver | None = None) -> EpisodeResult:
    """Dig the trench: scan, choose a dig, dig, settle, until done, no dig, or ``dig_budget`` digs
    (an :class:`Episode` cycled to its end).

    Args:
        sim: the world, as built (its seed sets the soil and the sensor noise).
        seed: the episode seed (the scanner's noise and drift).
        digs: where each cycle's dig comes from (default :class:`~excavsim.loop.digs.PlannedDigs` with
            the episode's :class:`~excavsim.planning.experience.DigExperience`).
        goal, dig_budget, done_fraction, tolerance_m, planner_cfg, executor_cfg, sensing_cfg, progress, observer:
            see :class:`Episode`.

    Returns:
        The digs' metrics and the trench against the goal on the true terrain; ``end`` is ``done``,
        ``no_dig``, ``budget``, ``diverged`` or ``timeout`` (see the module docstring).
    """
    episode = Episode(goal=goal, dig_budget=dig_budget, done_fraction=done_fraction, tolerance_m=tolerance_m,
                      planner_cfg=planner_cfg, executor_cfg=executor_cfg, sensing_cfg=sensing_cfg,
                      progress=progress, observer=observer)
    episode.reset(seed, sim=sim, digs=digs)
    return episode.run()


def _world_failed(exc: Diverged | OutOfTime, where: str) -> tuple[str, str]:
    """The episode's end and reason when the world failed outside a dig (``where``: what the loop was doing)."""
    return ("diverged" if isinstance(exc, Diverged) else "timeout"), f"{exc} ({where})"


def dig_metrics(index: int, dig: Dig, rec: ExecutionRecord, *, capacity: float, sim_s: float,
                ft_rate_hz: float, density_kg_m3: float) -> DigMetrics:
    """One dig's metrics. Torques cover the soil-loaded part of the dig (touch-down to the end of the
    lift-out): the moves through the air to the spoil and back are the servo's business, not the dig's."""
    lo, hi = rec.in_soil_window()
    tt = np.asarray(rec.times)
    sel = (tt >= lo) & (tt <= hi) if rec.torques else np.zeros(0, bool)
    torques = np.asarray(rec.torques)[sel] if sel.any() else np.zeros((1, 6))
    dt = 1.0 / ft_rate_hz
    weighed = rec.lifted_load_n / (density_kg_m3 * G_M_S2) if math.isfinite(rec.lifted_load_n) else 0.0
    return DigMetrics(
        index=index, kind=dig.kind, action=dig.action, outcome=rec.outcome, predicted_m3=dig.volume_m3,
        bucket_m3=rec.bucket_volume_m3, efficiency=rec.bucket_volume_m3 / capacity,
        stall_joint=rec.stall["joint"] if rec.stall else None, planning_s=dig.planning_s,
        sim_s=sim_s, peak_torque_nm=np.abs(torques).max(axis=0),
        cumulative_torque_nm_s=float(np.abs(torques).sum() * dt), predicted_peak_nm=dig.predicted_peak_nm,
        weighed_m3=float(weighed),
        failure=failure_kind(rec, weighed, MIN_USEFUL_M3))


def episode_result(sim: Simulation, digs: list[DigMetrics], end: str, reason: str, *, mask: np.ndarray,
                   z_goal: np.ndarray, h0: np.ndarray, v0: float, wall_s: float) -> EpisodeResult:
    """The trench against the goal on the true terrain (privileged), and the episode's totals."""
    h = sim.soil.grid.heights
    cell = sim.soil.grid.cell_area
    removed = float(np.clip(h0 - h, 0, None)[mask].sum() * cell)
    goal_m3 = float(np.clip(h0 - z_goal, 0, None)[mask].sum() * cell)
    over = np.append(np.clip(z_goal - h, 0, None)[mask], 0.0)  # below the goal profile (0 if off the box)
    under = np.append(np.clip(h - z_goal, 0, None)[mask], 0.0)  # soil still above it
    return EpisodeResult(
        digs=digs, end=end, reason=reason, goal_m3=goal_m3, removed_m3=removed, overdig_max_m=float(over.max()),
        overdig_rms_m=float(np.sqrt(np.mean(over[:-1] ** 2))) if over.size > 1 else 0.0,
        underdig_max_m=float(under.max()),
        underdig_rms_m=float(np.sqrt(np.mean(under[:-1] ** 2))) if under.size > 1 else 0.0,
        sim_time_s=sim.time, wall_time_s=wall_s, volume_change_m3=sim.soil.volumes().total - v0)
