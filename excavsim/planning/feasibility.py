"""The feasibility of cells of the action grid, and their longest admissible drag (Singh 1995 ch. 4-6).

A cell is an independent triple (k, alpha, d1) of the trenching action (§4.3: "the set of digs for
which there exists a valid value of the dependent parameters"). ``d2`` is the dependent variable
(§3.4.1): the longest drag on a ``sample_spacing_m`` grid that satisfies every constraint of
:mod:`~excavsim.planning.constraints`. It is bounded by the constraints along the drag (the count of
leading drag samples that pass each of them), then found by trying the curl from that bound down in
strides of four samples and refining upwards; a feasible drag that lies between strides below the
first feasible one can be missed (the curl's feasibility is not monotone in d2).

:class:`Feasibility` evaluates batches of cells on one map, vectorized over the cells and their
samples, constraints cheapest first on the survivors only (§6.2.2) when pruning. Penetrations are
judged per cell (:meth:`Feasibility.penetrations`) or, for the whole grid, once per (k, alpha) line
(:meth:`Feasibility.penetration_lines`); the two give the same verdicts up to the order of
floating-point sums. Both the exhaustive search (:mod:`~excavsim.planning.search`) and annealing
(:mod:`~excavsim.planning.anneal`) use it, so they share the constraints and the d2 rule.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from excavsim.config import PlannerConfig, TrenchGoal
from excavsim.handoff.forces import ForcePredictor, trajectory_progress
from excavsim.handoff.goal import SurfaceProfile
from excavsim.planning.action import (curl, curl_radius, padded_distances, penetrate, penetration_samples,
                                      running_total, soil_depth, swept)
from excavsim.planning.constraints import (ArmStatics, force, reachability, sensible, sensible_curl, shaping,
                                           torque_ratio, touchdown, volume)
from excavsim.planning.objectives import cumulative_torque, torque_sum

NO_DIG = -1  # drag index of a cell with no feasible drag
_CURL_STRIDE = 4  # drag samples between the curls tried first


def prune_along_d1(shaping_ok: np.ndarray, grid_shape: tuple[int, int, int]) -> np.ndarray:
    """(n,) cells to evaluate: those before the first penetration along d1 that cuts through the goal.

    §6.2.1: every longer penetration of the same (k, alpha) contains it. ``shaping_ok`` (n,) is
    whether each cell's penetration passes the shaping constraint, cells in C order of ``grid_shape``.
    """
    return np.cumprod(shaping_ok.reshape(grid_shape), axis=2).astype(bool).ravel()


@dataclasses.dataclass
class PenetrationVerdicts:
    """The constraints on the penetrations of m cells, and what they contribute to the whole dig.

    Attributes:
        shaping, sensible, reachability, force: (m,) bool, every sample passing.
        peak: (m,) largest torque ratio (``inf`` where unreachable or not evaluated).
        cum: (m,) cumulative torque (eq. 43) [N m m]; volume: (m,) swept volume [m^3].
        samples: poses evaluated, for the search's counts.
    """

    shaping: np.ndarray
    sensible: np.ndarray
    reachability: np.ndarray
    force: np.ndarray
    peak: np.ndarray
    cum: np.ndarray
    volume: np.ndarray
    samples: int

    def take(self, idx: np.ndarray) -> PenetrationVerdicts:
        """The verdicts of the cells ``idx``."""
        return dataclasses.replace(self, **{f.name: getattr(self, f.name)[idx] for f in dataclasses.fields(self)
                                            if f.name != "samples"})


@dataclasses.dataclass
class CellVerdicts:
    """The longest admissible drag of m cells and what their digs sweep and load.

    Attributes:
        j: (m,) drag samples of the longest admissible drag (d2 = j x ``sample_spacing_m``); ``NO_DIG``
            where none is.
        radius: (m,) its curl radius [m] (0 where none).
        volume, peak, cum: (m,) swept volume [m^3], peak torque ratio and cumulative torque (eq. 43)
            [N m m] of the whole dig; NaN where infeasible.
        masks: per constraint, (m,) the cells whose dig with the shortest drag satisfies it.
        counts: poses and curls evaluated per stage.
    """

    j: np.ndarray
    radius: np.ndarray
    volume: np.ndarray
    peak: np.ndarray
    cum: np.ndarray
    masks: dict[str, np.ndarray]
    counts: dict[str, int]


@dataclasses.dataclass(frozen=True, eq=False)
class Feasibility:
    """The constraints and the d2 rule on one map, for batches of cells (see the module docstring).

    Attributes:
        cfg: the planner's rules; goal: the trench; surface: the mapped surface along the arm plane.
        statics: the arm; predictor: the force model; density: the soil's [kg/m^3].
        limits: (3,) torque limits of the force constraint [N m] (``inf`` to switch it off).
        width: bucket width [m]; vmax: the volume constraint's limit [m^3].
    """

    cfg: PlannerConfig
    goal: TrenchGoal
    surface: SurfaceProfile
    statics: ArmStatics
    predictor: ForcePredictor
    density: float
    limits: np.ndarray
    width: float
    vmax: float

    def _reach(self, poses: np.ndarray) -> np.ndarray:
        return reachability(poses, self.statics)[0]

    def _loads(self, poses, depth, load_m3, progress):
        return torque_ratio(poses, depth, load_m3, statics=self.statics, predictor=self.predictor,
                            density=self.density, limits=self.limits, progress=progress, surface=self.surface)

    def penetrations(self, pen: np.ndarray, prune: bool) -> PenetrationVerdicts:
        """The verdicts on penetrations (m, P, 3), cell by cell; force only where reachable when ``prune``."""
        cfg, surface = self.cfg, self.surface
        m = pen.shape[0]
        shape_ok = np.all(shaping(pen, self.goal, cfg.shaping_tolerance_m), axis=1)
        sense_ok = np.all(sensible(pen, surface, cfg.surface_tolerance_m), axis=1)
        steps = swept(pen, surface, self.width)
        reach_ok = self._reach(pen).all(axis=1) & touchdown(pen[:, 0], self.statics, cfg.touchdown_reach_m)
        vcum = running_total(steps)
        depth = soil_depth(pen, surface)
        peak = np.full(m, np.inf)
        cum = np.zeros(m)
        sel = reach_ok if prune else np.ones(m, bool)
        if sel.any():
            prog = trajectory_progress(pen[sel], 0, math.radians(cfg.epsilon_deg))
            _, tau, ratio = self._loads(pen[sel], depth[sel], vcum[sel], prog)
            peak[sel] = ratio.max(axis=1)
            cum[sel] = cumulative_torque(tau, pen[sel])
        return PenetrationVerdicts(shape_ok, sense_ok, reach_ok, force(peak), peak, cum, steps.sum(axis=1),
                                   int(pen.shape[0] * pen.shape[1]))

    def penetration_lines(self, grid_k: np.ndarray, grid_alpha: np.ndarray, grid_d1: np.ndarray, k: np.ndarray,
                          alpha: np.ndarray, d1: np.ndarray) -> PenetrationVerdicts:
        """The verdicts on the penetrations of the whole grid, sharing the work along each (k, alpha) line.

        Every penetration of a (k, alpha) pair lies on one line from the entry point; its samples at
        multiples of the spacing are evaluated once per line and each cell adds only its end point
        (prefix AND / max / sum over the line's samples before d1).

        Args:
            grid_k, grid_alpha, grid_d1: the grid's axes [m, rad, m].
            k, alpha, d1: (n,) every cell's action, in C order of the grid.
        """
        cfg, surface = self.cfg, self.surface
        nk, na, nd = len(grid_k), len(grid_alpha), len(grid_d1)
        ds = cfg.sample_spacing_m
        eps = math.radians(cfg.epsilon_deg)
        n_s = penetration_samples(grid_d1.max(), ds)
        kl = np.repeat(grid_k, na)
        al = np.tile(grid_alpha, nk)
        line = penetrate(kl, al, padded_distances(np.full(kl.size, (n_s - 1) * ds), ds, n_s), surface, cfg)
        shape_i = shaping(line, self.goal, cfg.shaping_tolerance_m)
        sense_i = sensible(line, surface, cfg.surface_tolerance_m)
        vcum = running_total(swept(line, surface, self.width))
        reach_i = self._reach(line)
        _, tau, ratio = self._loads(line, soil_depth(line, surface), vcum, trajectory_progress(line, 0, eps))
        cum_i = running_total(torque_sum(tau)[:, 1:] * ds)
        # per cell: line samples 0 .. c-1 lie before d1, then the end point at d1
        li = np.arange(nk * na).repeat(nd)
        c = np.clip(np.ceil(d1 / ds - 1e-9).astype(np.int64), 1, n_s)
        last = c - 1
        cumall = lambda ok: np.cumprod(ok, axis=1).astype(bool)  # noqa: E731
        end = penetrate(k, alpha, d1[:, None], surface, cfg)[:, 0]
        prev = line[li, last]
        seg = np.stack([prev, end], axis=1)
        v_end = vcum[li, last] + swept(seg, surface, self.width)[:, 0]
        end_reach = self._reach(end[:, None, :])[:, 0]
        _, tau_e, ratio_e = self._loads(end, soil_depth(end, surface), v_end,
                                        np.stack([k, alpha, d1, np.zeros_like(d1)], axis=-1))
        peak_line = np.maximum.accumulate(np.where(np.isfinite(ratio), ratio, np.inf), axis=1)
        shape_ok = cumall(shape_i)[li, last] & shaping(end, self.goal, cfg.shaping_tolerance_m)
        sense_ok = cumall(sense_i)[li, last] & sensible(end, surface, cfg.surface_tolerance_m)
        entry_ok = touchdown(line[:, 0], self.statics, cfg.touchdown_reach_m)
        reach_ok = cumall(reach_i)[li, last] & end_reach & entry_ok[li]
        peak = np.where(reach_ok, np.maximum(peak_line[li, last], ratio_e), np.inf)
        seg_len = np.linalg.norm(end[:, :2] - prev[:, :2], axis=1)
        cum = cum_i[li, last] + torque_sum(tau_e) * seg_len
        return PenetrationVerdicts(shape_ok, sense_ok, reach_ok, force(peak), peak, cum, v_end,
                                   int(line.shape[0] * n_s + k.size))

    def evaluate(self, pen: np.ndarray, drag: np.ndarray, prune: bool,
                 penetration: PenetrationVerdicts | None = None) -> CellVerdicts:
        """The constraints and the longest admissible drag of m cells (vectorized).

        Args:
            pen: (m, P, 3) the cells' penetrations; drag: (m, J, 3) their drags up to ``d2_max_m``.
            prune: evaluate the expensive constraints only where the cheaper ones leave a dig;
                ``False`` evaluates every constraint on every sample (same answer, for figures).
            penetration: the penetrations' verdicts (e.g. from :meth:`penetration_lines`); None
                judges them here, cell by cell.
        """
        cfg, surface = self.cfg, self.surface
        m, n_j = drag.shape[:2]
        eps = math.radians(cfg.epsilon_deg)
        stage = {}
        p = self.penetrations(pen, prune) if penetration is None else penetration
        # Drag prefixes: count of leading samples passing each cheap constraint.
        d_shape = shaping(drag, self.goal, cfg.shaping_tolerance_m)
        d_sense = sensible(drag, surface, cfg.surface_tolerance_m)
        v_cum = p.volume[:, None] + running_total(swept(drag, surface, self.width))
        d_vol = volume(v_cum, self.vmax)
        lead = lambda ok: np.argmin(np.concatenate([ok, np.zeros((m, 1), bool)], axis=1), axis=1)  # noqa: E731
        j_shape, j_sense, j_vol = lead(d_shape), lead(d_sense), lead(d_vol)
        j_geo = np.minimum(np.minimum(j_shape, j_sense), j_vol)
        j_geo = np.where(p.shaping & p.sensible, j_geo, 0) if prune else np.full(m, n_j)
        # Reachability on penetrate + drag samples (only up to j_geo when pruning).
        live = np.arange(n_j)[None, :] < np.maximum(j_geo, 1)[:, None] if prune else np.ones((m, n_j), bool)
        d_reach = np.zeros((m, n_j), bool)
        sel = live & (p.reachability[:, None] | (not prune))
        stage["reach_samples"] = int(sel.sum()) + p.samples
        if sel.any():
            d_reach[sel] = self._reach(drag[sel])
        j_reach = lead(d_reach)
        # Force on the drag samples that are geometrically live.
        j_live = np.minimum(j_geo, j_reach) if prune else np.full(m, n_j)
        fsel = (np.arange(n_j)[None, :] < np.maximum(j_live, 1)[:, None]) & p.force[:, None] if prune else \
            np.ones((m, n_j), bool)
        ratio_d = np.full((m, n_j), np.inf)
        absum_d = np.zeros((m, n_j))
        stage["force_samples"] = int(fsel.sum()) + p.samples
        prog_d = trajectory_progress(drag, 1, eps, start=trajectory_progress(pen, 0, eps)[:, -1])
        if fsel.any():
            depth_d = soil_depth(drag, surface)
            _, tau, ratio = self._loads(drag[fsel], depth_d[fsel], v_cum[fsel], prog_d[fsel])
            ratio_d[fsel] = ratio
            absum_d[fsel] = torque_sum(tau)
        d_force = force(ratio_d)
        j_force = lead(d_force)
        # The longest drag whose curl also passes. Feasibility is not monotone in d2 (a short drag
        # leaves the rake too high to curl before the edge leaves the soil; a long one runs the curl
        # into the near wall), so scan down from the prefix bound in strides, then refine upward.
        j_all = np.minimum(np.minimum(j_shape, j_sense), np.minimum(j_vol, np.minimum(j_reach, j_force)))
        pen_ok = p.shaping & p.sensible & p.reachability & p.force
        best_j = np.full(m, NO_DIG)
        best_r = np.zeros(m)
        res_curl = {key: np.full(m, np.nan) for key in ("volume", "peak", "cum")}
        stage["curl_evaluations"] = 0

        def try_curl(cells: np.ndarray, jj: np.ndarray) -> None:
            stage["curl_evaluations"] += len(cells)
            ok, r, extra = self._curls(drag[cells, jj], v_cum[cells, jj], prog_d[cells, jj])
            better = ok & (jj > best_j[cells])
            win = cells[better]
            best_j[win] = jj[better]
            best_r[win] = r[better]
            for key, v in extra.items():
                res_curl[key][win] = v[better]

        hi = j_all - 1
        stride = _CURL_STRIDE
        for t in range(int(math.ceil(n_j / stride)) + 1):
            jj = hi - stride * t
            todo = np.nonzero(pen_ok & (jj >= 0) & (best_j == NO_DIG))[0]
            if todo.size == 0:
                break
            try_curl(todo, jj[todo])
        for up in range(stride - 1, 0, -1):  # refine: the largest j in (found, found + stride)
            jj = np.minimum(best_j + up, hi)
            todo = np.nonzero((best_j >= 0) & (jj > best_j))[0]
            if todo.size:
                try_curl(todo, jj[todo])
        # Per-cell results.
        feasible = best_j >= 0
        jsafe = np.maximum(best_j, 0)
        rows = np.arange(m)
        vol = np.where(feasible, v_cum[rows, jsafe] + res_curl["volume"], np.nan)
        prefix_peak = np.maximum.accumulate(np.where(np.isfinite(ratio_d), ratio_d, np.inf), axis=1)
        peak = np.where(feasible, np.maximum(np.maximum(p.peak, prefix_peak[rows, jsafe]), res_curl["peak"]), np.nan)
        ds = cfg.sample_spacing_m
        cum_d = np.cumsum(absum_d * ds, axis=1) - absum_d[:, :1] * ds
        cum = np.where(feasible, p.cum + cum_d[rows, jsafe] + res_curl["cum"], np.nan)
        # Per-constraint masks at the shortest drag (j = 0).
        geo0 = d_shape[:, 0] & d_sense[:, 0] & d_vol[:, 0]
        masks = {"shaping": p.shaping & d_shape[:, 0], "sensible": p.sensible & d_sense[:, 0], "volume": d_vol[:, 0],
                 "reachability": p.reachability & d_reach[:, 0] if not prune else p.reachability,
                 "force": p.force & (d_force[:, 0] | ~geo0)}
        return CellVerdicts(best_j, best_r, vol, peak, cum, masks, stage)

    def _curls(self, start: np.ndarray, v_before: np.ndarray, progress: np.ndarray | None
               ) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        """Smallest reachable curl radius per drag end pose (n, 3), whether that curl passes every
        constraint, and the curl's volume, peak torque ratio and cumulative torque."""
        cfg, surface = self.cfg, self.surface
        n = start.shape[0]
        radius = curl_radius(start, cfg, self._reach)
        has = np.isfinite(radius)
        ok = has.copy()
        extra = {"volume": np.zeros(n), "peak": np.zeros(n), "cum": np.zeros(n)}
        if not has.any():
            return ok, np.nan_to_num(radius), extra
        h = np.nonzero(has)[0]
        poses = curl(start[h], radius[h], cfg)
        shape_ok = np.all(shaping(poses, self.goal, cfg.shaping_tolerance_m), axis=1)
        sense_ok = sensible_curl(poses, surface, cfg.surface_tolerance_m, math.radians(cfg.curl_exit_pitch_deg))
        vol = v_before[h][:, None] + running_total(swept(poses, surface, self.width))
        vol_ok = volume(vol[:, -1], self.vmax)
        reach_ok = self._reach(poses).all(axis=1)
        eps = math.radians(cfg.epsilon_deg)
        prog = None if progress is None else trajectory_progress(poses, 2, eps, start=progress[h])
        _, tau, ratio = self._loads(poses, soil_depth(poses, surface), vol, prog)
        ok[h] = shape_ok & sense_ok & vol_ok & reach_ok & force(ratio.max(axis=1))
        extra["volume"][h] = vol[:, -1] - v_before[h]
        extra["peak"][h] = ratio.max(axis=1)
        extra["cum"][h] = cumulative_torque(tau, poses)
        return ok, np.nan_to_num(radius), extra
