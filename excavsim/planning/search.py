"""The exhaustive trenching planner: one dig on an elevation map (Singh 1995 ch. 6, §6.2).

:class:`TrenchPlanner` searches the discretized (k, alpha, d1) grid of the trenching action
(:mod:`~excavsim.planning.action`, §3.4) exhaustively (§6.2): it prunes along d1 at the first
penetration that cuts through the goal (§6.2.1: every longer penetration contains it), evaluates the
constraints (:mod:`~excavsim.planning.constraints`, ch. 4, §5.3) cheapest first on the surviving
cells only (§6.2.2) and finds each cell's longest admissible drag d2
(:mod:`~excavsim.planning.feasibility`); the objective then picks one feasible cell
(:mod:`~excavsim.planning.objectives`, eq. 44), or "no dig" when none is of minimum utility (the
loop's boundary-following fallback, §7.2). :class:`PlanResult` keeps what the search learned on the
way, per cell and per constraint, for the feasible-set figures (Figs. 38-49, Fig. 87).

With the nominal force model the search runs as one compiled per-candidate evaluation
(:mod:`~excavsim.planning.kernel`), the vectorized :class:`~excavsim.planning.feasibility.Feasibility`
being its reference, which other predictors, ``prune=False`` and ``classify_limits`` use; both give
the same answer. All of it is numpy and numba on :class:`~excavsim.robot.kinematics.PlanarArm` and the
elevation map: no MuJoCo.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from excavsim.config import PlannerConfig, TrenchGoal
from excavsim.errors import ConfigError, UsageError
from excavsim.handoff.dig import TrenchAction
from excavsim.handoff.forces import ForcePredictor, trajectory_progress
from excavsim.handoff.goal import SurfaceProfile
from excavsim.handoff.maps import ElevationMap
from excavsim.planning import action as geometry
from excavsim.planning import kernel as compiled
from excavsim.planning.constraints import (CONSTRAINTS, ArmStatics, PoseTorqueLimits, force, reachability, sensible,
                                           sensible_curl, shaping, torque_ratio, touchdown, volume)
from excavsim.planning.feasibility import NO_DIG, CellVerdicts, Feasibility, prune_along_d1
from excavsim.planning.objectives import choose
from excavsim.robot.kinematics import PlanarArm
from excavsim.robot.reachability import ReachabilityTable

__all__ = ["CONSTRAINTS", "PlanResult", "TrenchPlanner"]


@dataclasses.dataclass
class PlanResult:
    """The planner's answer and everything it learned on the way (for logs and figures).

    ``action`` is (k, alpha, d1, d2) [m, rad, m, m] or None for "no dig"; per-cell arrays have the
    grid's shape (n_k, n_alpha, n_d1). ``masks`` holds, per constraint, the cells whose dig with the
    shortest drag satisfies that constraint (evaluated on every cell, for figures) and
    ``feasible`` the cells with some drag satisfying all of them; ``curl_radius`` is each feasible
    cell's curl radius [m] (NaN elsewhere).
    """

    action: TrenchAction | None
    reason: str
    utility: float
    volume_m3: float
    poses: np.ndarray
    phases: np.ndarray
    forces: np.ndarray
    torques: np.ndarray
    grid_k: np.ndarray
    grid_alpha: np.ndarray
    grid_d1: np.ndarray
    feasible: np.ndarray
    d2: np.ndarray
    volume: np.ndarray
    peak_torque_ratio: np.ndarray
    cumulative_torque: np.ndarray
    curl_radius: np.ndarray
    limiting: np.ndarray
    masks: dict[str, np.ndarray]
    counts: dict[str, int]
    seconds: float
    # wall seconds of the feasible set's construction and of the selection (the objective's choice
    # and the chosen dig's path): Table 7's two planning rows
    timings: dict[str, float] = dataclasses.field(default_factory=dict)


class TrenchPlanner:
    """Plans one dig of a trench on an elevation map (see the module docstring).

    Args:
        arm: the planar chain.
        table: reachability table of ``arm``.
        torque_limits: (3,) relief limits of shoulder, elbow, wrist pitch [N m], or a cylinder machine's
            :class:`~excavsim.planning.constraints.PoseTorqueLimits` (relief pressure x area x moment arm
            at each sample's pose; the search then runs on the vectorized reference, not the kernel).
        bucket_width: [m]; bucket_capacity: struck capacity [m^3].
        goal: the trench.
        config: rules, grid and objective.
        predictor: force predictor for the force constraint (assignable: a learner may swap it).
        density: soil density for the load's weight [kg/m^3].
        kernel: search with the compiled kernel (:mod:`~excavsim.planning.kernel`) where it applies
            (a predictor with ``kernel_params``, ``prune``, no ``classify_limits``); False always uses
            the vectorized reference (:class:`~excavsim.planning.feasibility.Feasibility`). Same
            answer either way; assignable, and ``plan(kernel=...)`` overrides it for one plan.
    """

    def __init__(self, arm: PlanarArm, table: ReachabilityTable, torque_limits: np.ndarray, bucket_width: float,
                 bucket_capacity: float, goal: TrenchGoal, config: PlannerConfig, predictor: ForcePredictor,
                 density: float = 2000.0, *, kernel: bool = True):
        self.arm = arm
        self.limits = (torque_limits if isinstance(torque_limits, PoseTorqueLimits)
                       else np.asarray(torque_limits, dtype=float))
        nominal = self.limits.nominal if isinstance(self.limits, PoseTorqueLimits) else self.limits
        if nominal.shape != (3,) or np.any(nominal <= 0):
            raise ConfigError(f"torque_limits must be 3 positive values [N m]; given {torque_limits!r}")
        self.width = float(bucket_width)
        self.capacity = float(bucket_capacity)
        self.goal = goal
        self.cfg = config
        self.predictor = predictor
        self.density = float(density)
        self.kernel = bool(kernel)
        self._anneal_rng: np.random.Generator | None = None  # search: anneal (made at the first plan)
        self.statics = ArmStatics(arm, table, config.payload_com_tip_m)
        g = config.grid
        self.grid_k = _steps(g.k_min_m, g.k_max_m, g.k_step_m)
        self.grid_alpha = np.radians(_steps(g.alpha_min_deg, g.alpha_max_deg, g.alpha_step_deg))
        self.grid_d1 = _steps(g.d1_min_m, g.d1_max_m, g.d1_step_m)

    @property
    def table(self) -> ReachabilityTable:
        """The reachability table of the reachability constraint."""
        return self.statics.table

    @property
    def grid_shape(self) -> tuple[int, int, int]:
        return len(self.grid_k), len(self.grid_alpha), len(self.grid_d1)

    def grid_cells(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(k, alpha, d1) of every cell of the grid, (n,) each, flattened in C order of ``grid_shape``."""
        kk, aa, dd = np.meshgrid(self.grid_k, self.grid_alpha, self.grid_d1, indexing="ij")
        return kk.ravel(), aa.ravel(), dd.ravel()

    def surface(self, emap: ElevationMap) -> SurfaceProfile:
        """The mapped surface along the goal's arm plane, averaged across the bucket width."""
        return SurfaceProfile.from_map(emap, self.arm, math.radians(self.goal.waist_deg), self.width,
                                       clearance_m=self.cfg.wall_clearance_m)

    # -- the action's geometry ------------------------------------------------------------------
    def penetrate(self, k: np.ndarray, alpha: np.ndarray, d1: np.ndarray, surface: SurfaceProfile) -> np.ndarray:
        """(n, P, 3) penetrate poses for n actions every ``sample_spacing_m``, padded by repeating the end pose
        to the grid's longest penetration."""
        ds = self.cfg.sample_spacing_m
        s = geometry.padded_distances(d1, ds, geometry.penetration_samples(self.grid_d1.max(), ds))
        return geometry.penetrate(k, alpha, s, surface, self.cfg)

    def drag(self, start: np.ndarray) -> np.ndarray:
        """(n, J, 3) drag poses from penetrate end poses ``start`` (n, 3): sample j is d2 = j ds, up to ``d2_max_m``."""
        ds = self.cfg.sample_spacing_m
        n_j = int(math.floor(self.cfg.d2_max_m / ds + 1e-9)) + 1
        return geometry.drag(start, np.arange(n_j) * ds, self.cfg)

    def curl(self, start: np.ndarray, radius: np.ndarray) -> np.ndarray:
        """(n, M, 3) curl poses from drag end poses ``start`` (n, 3) about centres ``radius`` (n,) away
        (see :func:`~excavsim.planning.action.curl`)."""
        return geometry.curl(start, radius, self.cfg)

    def curl_radius(self, start: np.ndarray, *, default: float = math.nan) -> np.ndarray:
        """(n,) the smallest curl radius whose end pose is reachable from ``start`` (n, 3) (Fig. 23); ``default``
        where none is."""
        return geometry.curl_radius(start, self.cfg, lambda poses: self.reach(poses)[0], default=default)

    def trajectory(self, action: tuple[float, float, float, float], surface: SurfaceProfile,
                   radius: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Poses (S, 3) and phase labels (0 penetrate, 1 drag, 2 curl) of one action; ``radius`` None
        curls with the smallest radius whose end pose is reachable, as the search does."""
        return geometry.trajectory(action, surface, self.cfg, radius=radius,
                                   reachable=lambda poses: self.reach(poses)[0])

    def swept(self, poses: np.ndarray, surface: SurfaceProfile) -> np.ndarray:
        """Volume swept between consecutive samples of paths (..., S, 3) [m^3] (..., S-1)."""
        return geometry.swept(poses, surface, self.width)

    def swept_volume(self, poses: np.ndarray, surface: SurfaceProfile) -> float:
        """Soil a tip path (S, 3) sweeps between the mapped surface and itself, times the bucket width [m^3]."""
        return float(self.swept(poses, surface).sum())

    def path_loads(self, poses: np.ndarray, phases: np.ndarray, surface: SurfaceProfile
                   ) -> tuple[np.ndarray, np.ndarray]:
        """The predicted soil forces (S, 2) [N] and static joint torques (S, 3) [N m] along one trenching
        path (S, 3) with its phases (S,), the soil swept so far loading the bucket (eq. 28)."""
        vcum = geometry.running_total(self.swept(poses, surface))
        prog = trajectory_progress(poses, phases, math.radians(self.cfg.epsilon_deg))
        forces, torques, _ = self.torque_ratio(poses, geometry.soil_depth(poses, surface), vcum, prog, surface)
        return forces, torques

    # -- reachability and loads -----------------------------------------------------------------
    def reach(self, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Reachability (...,) and joint angles (..., 3) of tip poses (..., 3) (the reachability constraint)."""
        return reachability(poses, self.statics)

    def torque_ratio(self, poses: np.ndarray, depth: np.ndarray, load_m3: np.ndarray,
                     progress: np.ndarray | None = None, surface: SurfaceProfile | None = None
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Predicted forces, static joint torques (eq. 28) and the largest torque/limit ratio per sample
        with this planner's predictor and torque limits (see :func:`~excavsim.planning.constraints.torque_ratio`)."""
        return torque_ratio(poses, depth, load_m3, statics=self.statics, predictor=self.predictor,
                            density=self.density, limits=self.limits, progress=progress, surface=surface)

    # -- the search -----------------------------------------------------------------------------
    def feasibility(self, surface: SurfaceProfile, vmax: float, *, limits: np.ndarray | None = None) -> Feasibility:
        """The constraints and the d2 rule on ``surface`` with volume limit ``vmax`` [m^3], the force
        constraint within ``limits`` (default: the planner's torque limits)."""
        if limits is None:
            limits = self.limits
        elif not isinstance(limits, PoseTorqueLimits):
            limits = np.asarray(limits, dtype=float)
        return Feasibility(self.cfg, self.goal, surface, self.statics, self.predictor, self.density, limits,
                           self.width, vmax)

    def evaluate_cells(self, pen: np.ndarray, drag: np.ndarray, surface: SurfaceProfile, vmax: float, *,
                       prune: bool = True, limits: np.ndarray | None = None) -> CellVerdicts:
        """The constraints and longest admissible drag of the cells whose penetrations ``pen`` (m, P, 3)
        (:meth:`penetrate`) and drags ``drag`` (m, J, 3) (:meth:`drag`) are given, judged cell by cell
        (within ``limits``, default the planner's torque limits)."""
        return self.feasibility(surface, vmax, limits=limits).evaluate(pen, drag, prune)

    def uses_kernel(self, *, prune: bool = True, classify_limits: bool = False, kernel: bool | None = None) -> bool:
        """Whether :meth:`plan` with these arguments searches with the compiled kernel."""
        return bool((self.kernel if kernel is None else kernel) and prune and not classify_limits
                    and compiled.supports(self.predictor) and not isinstance(self.limits, PoseTorqueLimits))

    def plan(self, emap: ElevationMap, *, prune: bool = True, classify_limits: bool = False,
             exclude: np.ndarray | None = None, torque_margin: float = 1.0, kernel: bool | None = None) -> PlanResult:
        """Choose one dig on ``emap`` by exhaustive search over the grid (see the module docstring).

        Args:
            emap: the scanned elevation map (never the true terrain).
            prune: skip cells beyond the first goal-cutting penetration along d1 and evaluate
                constraints cheapest first on survivors only; ``False`` evaluates every constraint
                on every cell (same answer, for tests and figures).
            classify_limits: also search once more with the force constraint off, so that
                ``limiting`` tells what limits each cell (Fig. 87): 0 feasible, its drag d2 ended by
                the geometric constraints; 1 no dig that meets them; 2 geometrically feasible but
                no drag within the torque limits; 3 feasible, with d2 cut short by the force
                constraint. Without it, feasible cells are 0 and infeasible ones 1.
            exclude: (n_k, n_alpha, n_d1) bool, cells not to choose although they may be feasible
                (what failed before: :class:`~excavsim.planning.experience.DigExperience`); they stay
                in ``feasible`` and the masks, and are counted in ``counts["excluded"]``.
            torque_margin: the force constraint keeps every predicted joint torque within the limits
                divided by this factor (> 0): a margin (>= 1) for what the force model under-predicts,
                learned from the digs' measured torques
                (:meth:`~excavsim.planning.experience.DigExperience.torque_margin`); below 1 the
                constraint admits predicted torques that far over the limits (the loop's last
                resort when a learned model leaves no dig: the dig it predicts least over them).
            kernel: True or False to use the compiled kernel or the vectorized reference for this
                plan, where the kernel applies (:meth:`uses_kernel`); None: the planner's ``kernel``.
        """
        t0 = time.perf_counter()
        cfg = self.cfg
        if not (math.isfinite(torque_margin) and torque_margin > 0.0):
            raise ConfigError(f"torque_margin must be a finite factor > 0; given {torque_margin!r}")
        if cfg.search == "anneal" and prune:
            return self._plan_anneal(emap, t0, exclude, torque_margin)
        surface = self.surface(emap)
        k, alpha, d1 = self.grid_cells()
        n = k.size
        shape = self.grid_shape
        vmax = cfg.volume_limit_m3(self.capacity)
        counts = {"cells": n}
        if self.uses_kernel(prune=prune, classify_limits=classify_limits, kernel=kernel):
            feas = self.feasibility(surface, vmax, limits=self.limits / torque_margin)
            out = compiled.evaluate_grid(feas, self.grid_k, self.grid_alpha, self.grid_d1)
            counts["pruned_d1"] = int(n - out.alive.sum())
            counts["evaluated"] = int(out.alive.sum())
            counts.update(out.counts)
            return self._result(surface, t0, k, alpha, d1, out.j, out.radius,
                                {"volume": out.volume, "peak": out.peak, "cum": out.cum}, out.masks,
                                np.where(out.j >= 0, 0, 1).astype(np.int8), counts, exclude)

        # Penetration: shaping and sensible on every cell (cheap), then prune along d1.
        pen = self.penetrate(k, alpha, d1, surface)
        pen_shape = np.all(shaping(pen, self.goal, cfg.shaping_tolerance_m), axis=1)
        pen_sense = np.all(sensible(pen, surface, cfg.surface_tolerance_m), axis=1)
        alive = prune_along_d1(pen_shape, shape) if prune else np.ones(n, bool)
        counts["pruned_d1"] = int(n - alive.sum())

        drag_all = self.drag(pen[:, -1])
        res_j = np.full(n, NO_DIG)
        res_r = np.zeros(n)
        res = {key: np.full(n, np.nan) for key in ("volume", "peak", "cum")}
        masks = {c: np.zeros(n, bool) for c in CONSTRAINTS}
        limiting = np.ones(n, np.int8)  # see classify_limits

        idx = np.nonzero(alive)[0]
        counts["evaluated"] = idx.size
        if idx.size:
            feas = self.feasibility(surface, vmax, limits=self.limits / torque_margin)
            lines = feas.penetration_lines(self.grid_k, self.grid_alpha, self.grid_d1, k, alpha, d1)
            out = feas.evaluate(pen[idx], drag_all[idx], prune, lines.take(idx))
            res_j[idx], res_r[idx] = out.j, out.radius
            for key in res:
                res[key][idx] = getattr(out, key)
            for c in CONSTRAINTS:
                masks[c][idx] = out.masks[c]
            limiting[idx] = np.where(out.j >= 0, 0, 1)
            if classify_limits:
                free = dataclasses.replace(feas, limits=np.full(3, np.inf)).evaluate(pen[idx], drag_all[idx], prune)
                limiting[idx] = np.where(out.j >= 0, np.where(free.j > out.j, 3, 0), np.where(free.j >= 0, 2, 1))
            counts.update({k_: int(v) for k_, v in out.counts.items()})
        # Mask of the penetration constraints on every cell (pruned cells failed shaping).
        masks["shaping"] &= pen_shape
        masks["sensible"] &= pen_sense
        return self._result(surface, t0, k, alpha, d1, res_j, res_r, res, masks, limiting, counts, exclude)

    def _plan_anneal(self, emap: ElevationMap, t0: float, exclude: np.ndarray | None, torque_margin: float
                     ) -> PlanResult:
        """:meth:`plan` by simulated annealing (``search: anneal``, §6.3; :mod:`~excavsim.planning.anneal`).

        The chains evaluate cells exactly as the exhaustive search does (the same pruning, constraints,
        torque margin and exclusions), and the choice is the objective's over the cells evaluated;
        the per-cell arrays hold those cells only (the rest read infeasible, NaN), ``limiting`` is 0
        (feasible) or 1, and ``counts["evaluated"]`` counts them. The generator is the planner's own,
        seeded by ``anneal_seed``: an episode's plans are reproducible.
        """
        from excavsim.planning import anneal  # anneal builds on this module

        if self._anneal_rng is None:
            self._anneal_rng = np.random.default_rng(self.cfg.anneal_seed)
        n = int(np.prod(self.grid_shape))
        if exclude is not None and np.asarray(exclude).size != n:
            raise UsageError(f"exclude must have the grid's shape {self.grid_shape}; given {np.asarray(exclude).size} "
                             "cells")
        ev = anneal.CellEvaluator(self, emap, limits=self.limits / torque_margin, exclude=exclude)
        anneal.search(ev, self._anneal_rng, self.cfg.anneal_iterations, self.cfg.objective,
                      anneal.AnnealOptions(chains=self.cfg.anneal_chains))
        masks = {c: ev.masks.get(c, np.zeros(n, bool)) for c in CONSTRAINTS}
        counts = {"cells": n, "pruned_d1": int(n - ev.alive.sum()), "evaluated": int(ev.evaluated.sum()),
                  "visited": int(ev.visited.sum())}
        return self._result(ev.surface, t0, ev.k, ev.alpha, ev.d1, ev.j, ev.radius, ev.res, masks,
                            np.where(ev.j >= 0, 0, 1).astype(np.int8), counts, exclude)

    def _result(self, surface, t0, k, alpha, d1, res_j, res_r, res, masks, limiting, counts, exclude
                ) -> PlanResult:
        """The choice among the feasible cells and its path: the :class:`PlanResult` of :meth:`plan`."""
        t_select = time.perf_counter()
        cfg = self.cfg
        n = k.size
        shape = self.grid_shape
        feasible = res_j >= 0
        d2 = res_j * cfg.sample_spacing_m
        allowed = feasible
        if exclude is not None:
            exclude = np.asarray(exclude, dtype=bool).reshape(-1)
            if exclude.shape != (n,):
                raise UsageError(f"exclude must have the grid's shape {shape}; given {exclude.size} cells")
            allowed = feasible & ~exclude
            counts["excluded"] = int((feasible & exclude).sum())
        choice, utility, reason = choose(allowed, res["volume"], res["peak"], res["cum"], cfg, self.capacity)
        action = None
        poses = np.zeros((0, 3))
        phases = np.zeros(0, np.int8)
        forces = np.zeros((0, 2))
        torques = np.zeros((0, 3))
        vol = 0.0
        if choice is not None:
            c = choice
            action = TrenchAction(float(k[c]), float(alpha[c]), float(d1[c]), int(res_j[c]) * cfg.sample_spacing_m)
            poses, phases = self.trajectory(action, surface, radius=float(res_r[c]))
            forces, torques = self.path_loads(poses, phases, surface)
            vol = float(res["volume"][c])
        return PlanResult(
            action=action, reason=reason, utility=utility, volume_m3=vol, poses=poses, phases=phases, forces=forces,
            torques=torques, grid_k=self.grid_k, grid_alpha=self.grid_alpha, grid_d1=self.grid_d1,
            feasible=feasible.reshape(shape), d2=np.where(feasible, d2, np.nan).reshape(shape),
            volume=res["volume"].reshape(shape), peak_torque_ratio=res["peak"].reshape(shape),
            cumulative_torque=res["cum"].reshape(shape), curl_radius=np.where(feasible, res_r, np.nan).reshape(shape),
            limiting=limiting.reshape(shape),
            masks={c: m.reshape(shape) for c, m in masks.items()}, counts=counts,
            seconds=time.perf_counter() - t0,
            timings={"feasible_s": t_select - t0, "select_s": time.perf_counter() - t_select},
        )

    def check_action(self, emap: ElevationMap, action: tuple[float, float, float, float],
                     radius: float | None = None) -> dict[str, bool]:
        """Each constraint's verdict on one fully specified dig (k, alpha, d1, d2), plus its volume.

        The same tests as the search, on the whole path of this one action: for inspecting a dig,
        and for the executor to re-check a plan against a fresh map.
        """
        cfg = self.cfg
        surface = self.surface(emap)
        poses, phases = self.trajectory(action, surface, radius)
        body = poses[phases < 2]
        curl = poses[phases == 2]
        in_soil = bool(np.all(sensible(body, surface, cfg.surface_tolerance_m)))
        exit_ok = bool(sensible_curl(curl, surface, cfg.surface_tolerance_m, math.radians(cfg.curl_exit_pitch_deg)))
        vcum = geometry.running_total(self.swept(poses, surface))
        reachable = bool(self.reach(poses[None])[0].all()
                         and touchdown(poses[0], self.statics, cfg.touchdown_reach_m))
        force_ok = False
        if reachable:
            prog = trajectory_progress(poses, phases, math.radians(cfg.epsilon_deg))
            _, _, ratio = self.torque_ratio(poses, geometry.soil_depth(poses, surface), vcum, prog, surface)
            force_ok = bool(np.all(force(ratio)))
        return {"shaping": bool(np.all(shaping(poses, self.goal, cfg.shaping_tolerance_m))),
                "sensible": in_soil and exit_ok,
                "volume": bool(volume(vcum[-1], cfg.volume_limit_m3(self.capacity))), "reachability": reachable,
                "force": force_ok, "volume_m3": float(vcum[-1])}


def _steps(lo: float, hi: float, step: float) -> np.ndarray:
    n = int(math.floor((hi - lo) / step + 1e-9)) + 1
    return lo + step * np.arange(n)
