"""Simulated annealing over the trenching action space (Singh 1995 §6.3).

The alternative to :meth:`~excavsim.planning.search.TrenchPlanner.plan`'s exhaustive search that
the thesis proposes (§1.4, §2.2.2, §6.3, [Bohachevsky86]): "a stochastic gradient descent method. A
random element whose standard deviation decreases exponentially with time is added ..." (§6.3); "a
step is always taken if it improves the error metric but is sometimes taken (based on an
exponentially decreasing random variable) even if it results in a worse metric" (§5.2.1). Each
constraint is only a pass/fail test, so nothing needs to be smooth.

The search runs on the planner's own discretized (k, alpha, d1) grid, so its answer is one of the
cells the exhaustive search considers. A :class:`CellEvaluator` evaluates batches of cells exactly
as ``plan(prune=True)`` does (the same d1 pruning, the same
:class:`~excavsim.planning.feasibility.Feasibility`, hence the same constraints and the same longest
admissible drag d2) and caches every cell it has evaluated.
The annealer keeps ``chains`` Metropolis chains over grid indices, proposes for all of them at once
(one batch per iteration), and shrinks both the proposal's standard deviation and the temperature
exponentially from their start to their end values over ``maxiter`` iterations; a greedy descent
over the 26 neighbouring cells of the best cell finishes it (the "modified to be practical" step
of §6.3). The final choice is :func:`~excavsim.planning.objectives.choose` over the evaluated cells,
so the objective, its utility and the "no dig" rule are the planner's.

The energy the chains descend orders cells as the objective does (:func:`~excavsim.planning.objectives.choose`):

* ``lexicographic`` (eq. 44): the peak torque ratio (in [0, 1]) for digs sweeping at least
  ``volume_threshold`` (and ``min_volume_fraction``) of the capacity; ``1 + (v_goal - volume) /
  v_goal`` (in (1, 2]) for smaller digs, so that volume leads the search towards the threshold;
* ``peak_torque``: likewise with ``v_goal`` the ``min_volume_fraction`` of the capacity (smaller
  digs are "no dig" to ``choose``); ``cumulative_torque``: likewise with ``x / (1 + x)`` for the
  peak, ``x`` the cumulative torque over ``sum(torque_limits) x 0.1 m`` (a monotone squashing that
  only sets the temperature's scale);
* ``volume``: ``-volume / capacity``;
* infeasible cells get a constant penalty above every feasible energy (a plateau the chains walk).

What it buys: a near-optimal dig from a small share of the grid's cells (the README gives the
measured share and gap). With the compiled kernel it costs about a third of ``plan`` (measured on the
flat fill of the sand trench: 14 against 45 ms CPU); with the vectorized reference (``planner.kernel``
False, or a learned predictor) it is not faster than ``plan``, which evaluates its surviving cells in
one batch where this pays a batch per iteration. Like any annealer it can miss a feasible
set of a few isolated cells: it then answers "no dig".

numpy, and the planner's compiled kernel, like the rest of ``planning/``.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from excavsim.errors import ConfigError
from excavsim.handoff.dig import TrenchAction
from excavsim.handoff.maps import ElevationMap
from excavsim.planning import kernel
from excavsim.planning.constraints import PoseTorqueLimits, shaping
from excavsim.planning.feasibility import prune_along_d1
from excavsim.planning.objectives import OBJECTIVES, choose
# TrenchPlanner (excavsim.planning.search) appears in annotations only: search imports this module for
# its ``search: anneal`` (TrenchPlanner.plan), so importing it back would make a cycle.

__all__ = ["OBJECTIVES", "AnnealOptions", "AnnealResult", "CellEvaluator", "anneal", "cell_energy", "search"]
# Energy of an infeasible cell, per objective: above every feasible energy (see the module docstring).
_PENALTY = {"lexicographic": 3.0, "volume": 1.0, "peak_torque": 3.0, "cumulative_torque": 3.0}
_CUM_SCALE_M = 0.1  # cumulative-torque energy scale: the torque limits' sum over this path length [m]
# The 26 neighbours of a cell (greedy polish).
_NEIGHBOURS = np.array([(a, b, c) for a in (-1, 0, 1) for b in (-1, 0, 1) for c in (-1, 0, 1) if a or b or c])


@dataclasses.dataclass(frozen=True)
class AnnealOptions:
    """The annealer's black-box parameters (§6.4: "the rate at which the randomization decreases").

    Attributes:
        chains: Metropolis chains run side by side (one batch of proposals per iteration).
        t_start, t_end: temperature at the first and last iteration [energy units, see the module
            docstring]; it falls exponentially between them.
        step_start, step_end: standard deviation of a proposal's step at the first and last
            iteration, as a fraction of the grid's extent along each axis (step_start) and in grid
            cells (step_end); it falls exponentially between them.
        polish: finish with a greedy descent over the best cell's 26 neighbours.
    """

    chains: int = 16
    t_start: float = 0.5
    t_end: float = 0.005
    step_start: float = 0.3
    step_end: float = 0.6
    polish: bool = True

    def __post_init__(self):
        if self.chains < 1:
            raise ConfigError(f"AnnealOptions.chains={self.chains}; it must be at least 1")
        for name in ("t_start", "t_end", "step_start", "step_end"):
            if not getattr(self, name) > 0:
                raise ConfigError(f"AnnealOptions.{name}={getattr(self, name)}; it must be positive")


@dataclasses.dataclass
class AnnealResult:
    """The annealer's answer, in the terms of :class:`~excavsim.planning.search.PlanResult`.

    ``action`` is (k, alpha, d1, d2) [m, rad, m, m] or None for "no dig" (nothing feasible among
    the evaluated cells, or the best sweeps less than ``min_volume_fraction`` of the capacity);
    ``utility`` and ``reason`` are the objective's choice on the evaluated cells. ``cell`` is
    the chosen (i_k, i_alpha, i_d1). ``evaluated`` has the grid's shape (n_k, n_alpha, n_d1) and
    marks the cells passed to the planner's evaluation; ``cells_visited`` also counts the cells the
    search touched that the d1 pruning rejected without evaluation. ``best_energy`` (maxiter + 1,)
    is the best energy after the initial batch and after each iteration.
    """

    action: TrenchAction | None
    reason: str
    utility: float
    volume_m3: float
    peak_torque_ratio: float
    cumulative_torque: float
    curl_radius_m: float
    cell: tuple[int, int, int] | None
    objective: str
    cells_evaluated: int
    cells_visited: int
    cells_total: int
    evaluated: np.ndarray
    best_energy: np.ndarray
    seconds: float

    @property
    def fraction_evaluated(self) -> float:
        """Share of the grid's cells the search evaluated."""
        return self.cells_evaluated / self.cells_total


class CellEvaluator:
    """Evaluates cells of a planner's grid exactly as ``TrenchPlanner.plan(prune=True)`` does, with a cache.

    Cells are flat indices into the grid of shape ``planner.grid_shape`` (C order, as ``plan``
    flattens it). A cell beyond the first goal-cutting penetration along d1 is infeasible without
    evaluation (``plan``'s pruning, a cheap geometric test done on the whole grid at construction);
    the others are evaluated once each, in batches: by the compiled kernel when the planner uses it
    (:func:`~excavsim.planning.kernel.evaluate_cells`, exactly as ``plan`` judges them), else by
    ``planner.evaluate_cells`` with their penetrations' verdicts computed per cell (``plan`` shares
    that work along each (k, alpha) line for the whole grid; the verdicts are the same, up to the
    order of floating-point sums).

    Args:
        planner: the exhaustive planner whose grid, constraints and per-cell evaluation are used.
        emap: the scanned elevation map.
    """

    def __init__(self, planner: TrenchPlanner, emap: ElevationMap, *, limits: np.ndarray | None = None,
                 exclude: np.ndarray | None = None):
        self.planner = planner
        self.limits = planner.limits if limits is None else (
            limits if isinstance(limits, PoseTorqueLimits) else np.asarray(limits, dtype=float))
        cfg = planner.cfg
        self.surface = planner.surface(emap)
        self.shape = planner.grid_shape
        self.k, self.alpha, self.d1 = planner.grid_cells()
        n = self.k.size
        self.vmax = cfg.volume_limit_m3(planner.capacity)
        # plan's d1 pruning: alive up to the first penetration that cuts through the goal.
        pen = planner.penetrate(self.k, self.alpha, self.d1, self.surface)
        self.alive = prune_along_d1(np.all(shaping(pen, planner.goal, cfg.shaping_tolerance_m), axis=1), self.shape)
        self.visited = np.zeros(n, bool)
        self.evaluated = np.zeros(n, bool)
        self.feasible = np.zeros(n, bool)
        self.j = np.full(n, -1)
        self.radius = np.zeros(n)
        self.res = {key: np.full(n, np.nan) for key in ("volume", "peak", "cum")}
        self.masks: dict[str, np.ndarray] = {}  # per constraint, on the evaluated cells (kernel only)
        # cells not to choose (plan's ``exclude``): the search treats them as infeasible
        self.excluded = np.zeros(n, bool) if exclude is None else np.asarray(exclude, dtype=bool).reshape(-1)

    def __call__(self, cells: np.ndarray) -> np.ndarray:
        """Evaluate ``cells`` (m,) flat indices (repeats allowed); returns their feasibility (m,) bool.

        Their volume, peak and cumulative torque are then in ``self.res`` (NaN where infeasible).
        """
        cells = np.asarray(cells, dtype=np.int64)
        self.visited[cells] = True
        todo = np.unique(cells)
        todo = todo[self.alive[todo] & ~self.evaluated[todo]]
        if todo.size:
            p = self.planner
            if p.uses_kernel():
                out = kernel.evaluate_cells(p.feasibility(self.surface, self.vmax, limits=self.limits), p.grid_k,
                                            p.grid_alpha, p.grid_d1, todo)
                for c, m in out.masks.items():
                    self.masks.setdefault(c, np.zeros(self.k.size, bool))[todo] = m
            else:
                pen = p.penetrate(self.k[todo], self.alpha[todo], self.d1[todo], self.surface)
                out = p.evaluate_cells(pen, p.drag(pen[:, -1]), self.surface, self.vmax, limits=self.limits)
            self.evaluated[todo] = True
            self.j[todo], self.radius[todo] = out.j, out.radius
            self.feasible[todo] = out.j >= 0
            for key in self.res:
                self.res[key][todo] = getattr(out, key)
        return self.feasible[cells]


def cell_energy(ev: CellEvaluator, cells: np.ndarray, objective: str) -> np.ndarray:
    """Energy (m,) of the flat ``cells`` under ``objective``; lower is better (see the module docstring)."""
    ok = ev(cells) & ~ev.excluded[cells]
    p = ev.planner
    vol, peak, cum = (ev.res[key][cells] for key in ("volume", "peak", "cum"))
    if objective == "volume":
        return np.where(ok, -vol / p.capacity, _PENALTY[objective])
    # The torque objectives rank the digs sweeping enough (choose's "useful": at least
    # min_volume_fraction of the capacity; eq. 44: at least volume_threshold too); volume ranks the rest.
    v_goal = p.cfg.min_volume_fraction * p.capacity
    if objective == "lexicographic":
        v_goal = max(v_goal, p.cfg.volume_threshold * p.capacity)
    if objective == "peak_torque" or (objective == "lexicographic" and p.cfg.auxiliary == "peak_torque"):
        good = peak
    else:
        x = cum / (p.limits.sum() * _CUM_SCALE_M)
        good = x / (1.0 + x)
    short = 1.0 + (v_goal - vol) / v_goal if v_goal > 0 else np.ones_like(vol)
    return np.where(ok, np.where(vol >= v_goal, good, short), _PENALTY[objective])


def anneal(planner: TrenchPlanner, emap: ElevationMap, *, seed: int | np.random.Generator = 0, maxiter: int = 20,
           objective: str | None = None, options: AnnealOptions = AnnealOptions()) -> AnnealResult:
    """Choose one dig on ``emap`` by simulated annealing over the planner's grid (see the module docstring).

    Args:
        planner: the exhaustive planner; its grid, constraints, d2 rule and objective are used.
        emap: the scanned elevation map (never the true terrain).
        seed: seeds the search's ``numpy.random.Generator`` (or is that generator); the same seed
            gives the same result.
        maxiter: annealing iterations; each proposes one move per chain, so at most
            ``options.chains x (maxiter + 1)`` cells are evaluated before the polish.
        objective: one of ``OBJECTIVES``; None uses ``planner.cfg.objective``.
        options: the cooling schedule and chain count.

    Returns:
        The chosen action (or None), its utility, volume and torques, and what the search cost.

    Raises:
        ExcavsimError: an unknown ``objective`` or a negative ``maxiter``.
    """
    t0 = time.perf_counter()
    objective = planner.cfg.objective if objective is None else objective
    if objective not in OBJECTIVES:
        raise ConfigError(f"objective={objective!r}; allowed: {', '.join(OBJECTIVES)}")
    if maxiter < 0:
        raise ConfigError(f"maxiter={maxiter}; it must be >= 0")
    rng = np.random.default_rng(seed)
    ev = CellEvaluator(planner, emap)
    trace = search(ev, rng, maxiter, objective, options)
    choice, utility, reason = choose(ev.feasible, ev.res["volume"], ev.res["peak"], ev.res["cum"], planner.cfg,
                                     planner.capacity, objective=objective)
    action, cell = None, None
    volume = peak = cum = radius = 0.0
    if choice is not None:
        action = TrenchAction(float(ev.k[choice]), float(ev.alpha[choice]), float(ev.d1[choice]),
                              int(ev.j[choice]) * planner.cfg.sample_spacing_m)
        cell = tuple(int(i) for i in np.unravel_index(choice, ev.shape))
        volume, peak, cum = (float(ev.res[key][choice]) for key in ("volume", "peak", "cum"))
        radius = float(ev.radius[choice])
    return AnnealResult(
        action=action, reason=reason, utility=utility, volume_m3=volume, peak_torque_ratio=peak,
        cumulative_torque=cum, curl_radius_m=radius, cell=cell, objective=objective,
        cells_evaluated=int(ev.evaluated.sum()), cells_visited=int(ev.visited.sum()), cells_total=ev.k.size,
        evaluated=ev.evaluated.reshape(ev.shape), best_energy=trace, seconds=time.perf_counter() - t0,
    )


def search(ev: CellEvaluator, rng: np.random.Generator, maxiter: int, objective: str,
           options: AnnealOptions = AnnealOptions()) -> np.ndarray:
    """Run the annealing chains (and the polish) on ``ev``; returns the best energy per iteration.

    What :func:`anneal` does before its choice, for a caller that chooses itself
    (:meth:`~excavsim.planning.search.TrenchPlanner.plan` with ``search: anneal``): the cells it
    evaluated are then in ``ev``.
    """
    energy = lambda idx: cell_energy(ev, np.ravel_multi_index(idx.T, ev.shape), objective)  # noqa: E731
    shape = np.array(ev.shape)

    c = options.chains
    cur = rng.integers(0, shape, size=(c, 3))
    e_cur = energy(cur)
    best_i = int(np.argmin(e_cur))
    best, e_best = cur[best_i].copy(), float(e_cur[best_i])
    trace = np.empty(maxiter + 1)
    trace[0] = e_best
    sigma0 = options.step_start * shape
    for it in range(maxiter):
        frac = it / max(maxiter - 1, 1)
        temp = options.t_start * (options.t_end / options.t_start) ** frac
        sigma = sigma0 * (options.step_end / sigma0) ** frac
        step = np.rint(rng.normal(size=(c, 3)) * sigma).astype(np.int64)
        # A step that rounds to zero moves one cell along a random axis instead.
        axis, sign = rng.integers(0, 3, size=c), rng.choice((-1, 1), size=c)
        still = ~step.any(axis=1)
        step[still, axis[still]] = sign[still]
        prop = _reflect(cur + step, shape)
        e_prop = energy(prop)
        u = rng.random(c)
        accept = (e_prop <= e_cur) | (u < np.exp(-np.maximum(e_prop - e_cur, 0.0) / temp))
        cur = np.where(accept[:, None], prop, cur)
        e_cur = np.where(accept, e_prop, e_cur)
        i = int(np.argmin(e_cur))
        if e_cur[i] < e_best:
            best, e_best = cur[i].copy(), float(e_cur[i])
        trace[it + 1] = e_best

    if options.polish:
        while True:
            nb = np.unique(np.clip(best + _NEIGHBOURS, 0, shape - 1), axis=0)
            e_nb = energy(nb)
            i = int(np.argmin(e_nb))
            if not e_nb[i] < e_best:
                break
            best, e_best = nb[i].copy(), float(e_nb[i])
    return trace


def _reflect(idx: np.ndarray, shape: np.ndarray) -> np.ndarray:
    """Grid indices (n, 3) folded back into [0, shape) at the edges (a mirror, not a wall)."""
    hi = shape - 1
    period = np.maximum(2 * hi, 1)
    m = np.mod(idx, period)
    return np.where(m > hi, period - m, m)
