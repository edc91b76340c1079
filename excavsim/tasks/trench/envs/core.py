"""The trench's dig-level core: the trenching episode one dig at a time, free of any RL library.

:class:`DigCore` is the core of ``excavsim/TrenchDig-v0`` (its Gymnasium face
:class:`~excavsim.tasks.trench.envs.dig_env.TrenchDigEnv`, its dm_env face
:class:`~excavsim.tasks.trench.envs.dm.DmTrenchDig`). The episode is the loop's own
(:class:`~excavsim.loop.episode.Episode`, what ``excavsim trench`` runs), stepped phase by phase in the
caller's thread (:class:`~excavsim.envs.core.DigLevelCore`) with the planner's dig source
(:class:`~excavsim.tasks.trench.digs.PlannedDigs`), the agent's trenching action in place of the planner's
choice. The episode's wall clock stops while the agent thinks. The planner's choice on the same map is
computed each cycle anyway (it gives the feasible set, each cell's drag d2 and its curl), and when the
agent's action falls on the planner's cell the planner's dig is dug as it is, so the planner used as a
policy reproduces ``excavsim trench`` dig for dig.

Observations are what the robot senses (scanned maps, the F/T sensor), never the true terrain; rewards are
measured on the true terrain (:class:`TrueTrench`, shared with the joint-level trench goal), as the episode
summary's removed volume and over-dig are.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from excavsim.config import TrenchGoal
from excavsim.envs.core import DigLevelCore, EnvError, Field, as_spec, check_weights
from excavsim.handoff.dig import Dig, TrenchAction
from excavsim.handoff.episode import EpisodeObserver, EpisodeResult
from excavsim.handoff.goal import goal_profile
from excavsim.handoff.maps import ElevationMap
from excavsim.loop.digs import Choice
from excavsim.loop.scenario import dig_rows, episode_summary, resolve, spec_episode
from excavsim.planning.experience import DigExperience
from excavsim.tasks.trench.digs import PlannedDigs
from excavsim.tasks.trench.plugin import NAME
from excavsim.tasks.trench.task import map_done
from excavsim.world.simulation import Simulation

OUTCOMES = ("none", "completed", "completed late", "stalled", "no contact", "failed")
"""The last dig's outcome as an index: ``none`` before the first dig; ``failed`` covers the script's
timeout, a divergence and a simulation failure."""
TIMING_KEYS = ("planning_s", "wall_s")  # wall-clock numbers left out of ``info`` (they differ run to run)


def outcome_index(outcome: str | None) -> int:
    """The index in :data:`OUTCOMES` of an execution outcome (None: no dig yet)."""
    if outcome is None:
        return 0
    return OUTCOMES.index(outcome) if outcome in OUTCOMES else OUTCOMES.index("failed")


class GoalWindow:
    """A grid of points in the goal's arm plane around the trench, where the dig environment samples
    the scanned map: radially from ``margin_m`` before the near edge to ``margin_m`` past the far
    edge, laterally ``half_width_m`` either side of the plane, every ``spacing_m``.

    Rows run along the lateral axis (towards +y at waist 0), columns radially away from the robot.
    World points use the loop's convention for the trench's footprint
    (:func:`~excavsim.rig.measures.trench_footprint`): the arm plane through the waist axis.
    """

    def __init__(self, goal: TrenchGoal, spacing_m: float, margin_m: float, half_width_m: float):
        for name, v in (("spacing_m", spacing_m), ("margin_m", margin_m), ("half_width_m", half_width_m)):
            if not (math.isfinite(v) and v >= 0) or (name == "spacing_m" and v <= 0):
                raise EnvError(f"window {name} must be a finite number {'>' if name == 'spacing_m' else '>='} 0; "
                               f"given {v!r}")
        self.goal = goal
        n_r = int(math.floor((goal.far_x_m - goal.near_x_m + 2 * margin_m) / spacing_m + 1e-9)) + 1
        n_l = 2 * int(math.floor(half_width_m / spacing_m + 1e-9)) + 1
        self.radial = goal.near_x_m - margin_m + spacing_m * np.arange(n_r)
        self.lateral = spacing_m * (np.arange(n_l) - n_l // 2)
        r, lat = np.meshgrid(self.radial, self.lateral)
        w = math.radians(goal.waist_deg)
        self.x = r * math.cos(w) - lat * math.sin(w)
        self.y = r * math.sin(w) + lat * math.cos(w)
        self._r, self._lat = r, lat

    @property
    def shape(self) -> tuple[int, int]:
        """(lateral samples, radial samples)."""
        return self.x.shape

    def goal_layers(self, width: float) -> tuple[np.ndarray, np.ndarray]:
        """The goal mask (1 inside the trench's footprint of bucket ``width`` [m], else 0) and the depth
        to dig below ``surface_z_m`` at each point [m] (0 outside), float32 (lateral, radial)."""
        mask = (np.abs(self._lat) <= width / 2) & (self._r >= self.goal.near_x_m) & (self._r <= self.goal.far_x_m)
        depth = np.where(mask, self.goal.surface_z_m - goal_profile(self.goal, self._r), 0.0)
        return mask.astype(np.float32), depth.astype(np.float32)

    def elevation(self, emap: ElevationMap) -> np.ndarray:
        """The map's heights at the points, relative to the goal's ``surface_z_m`` [m], float32."""
        return (emap.height_at(self.x, self.y) - self.goal.surface_z_m).astype(np.float32)


class TrueTrench:
    """The trench against its goal on the true terrain (privileged: for rewards only), as the
    loop's episode result measures it: soil removed above the goal profile inside the footprint,
    and the over-dig below it [m^3]."""

    def __init__(self, sim: Simulation, mask: np.ndarray, z_goal: np.ndarray):
        self.sim = sim
        self.idx = np.nonzero(mask)
        self.z_goal = z_goal[self.idx]
        self.h0 = sim.soil.grid.heights[self.idx].copy()
        self.cell_area = sim.soil.grid.cell_area
        self.goal_m3 = float(np.clip(self.h0 - self.z_goal, 0, None).sum() * self.cell_area)

    def measure(self) -> tuple[float, float]:
        """(removed above the goal, over-dig below it) [m^3] now."""
        h = self.sim.soil.grid.heights[self.idx]
        removed = float(np.clip(self.h0 - np.maximum(h, self.z_goal), 0, None).sum() * self.cell_area)
        over = float(np.clip(self.z_goal - h, 0, None).sum() * self.cell_area)
        return removed, over


# -- the dig level ------------------------------------------------------------------------------
DIG_WEIGHTS = {"removed_per_l": 1.0, "overdig_per_l": 2.0, "stall": 5.0}
"""The dig environment's default reward weights: per litre removed inside the goal, per litre dug
below the goal profile, per stalled dig."""


@dataclasses.dataclass
class _Decision:
    """Where the episode stands for the agent: the map and the planner's action of a cycle that
    waits for the agent's action, or the episode's result when it ended."""

    emap: ElevationMap | None = None
    planner_action: TrenchAction | None = None
    planner_fell_back: bool = False
    result: EpisodeResult | None = None


class _AgentDigs(PlannedDigs):
    """The planner's dig source, remembering the scanned map's profile of the cycle (before the
    experience's bounds), where the agent's cells are excluded as the planner's are (see :class:`DigCore`)."""

    def __init__(self, experience: DigExperience | None):
        super().__init__(experience)
        self.scanned_surface = None

    def belief(self, rig, emap):
        self.scanned_surface = rig.planner.surface(emap)
        return super().belief(rig, emap)


class DigCore(DigLevelCore):
    """The trenching episode, one step per dig (the core of ``excavsim/TrenchDig-v0``).

    Each step digs one trenching action (k, alpha, d1) [m, rad, m]. The action is snapped to the
    nearest cell of the planner's (k, alpha, d1) grid; its drag d2 and curl are the planner's for
    that cell on the current map (the longest feasible d2, :meth:`TrenchPlanner.plan
    <excavsim.planning.search.TrenchPlanner.plan>`). A cell the planner finds infeasible (or that its
    memory of failed digs excludes) is dug as the nearest allowed cell of the grid (Euclidean in grid
    steps; ties to the first in C order); ``info`` reports the requested and the executed cell. With
    ``fallback`` (the default), a cycle in which the planner finds no trenching dig of minimum
    utility digs the loop's boundary-following fallback, as ``excavsim trench`` does, and the
    agent's action is not used (``info["action_used"]`` False); without it the agent's nearest
    allowed cell is dug whatever its volume, and the episode ends (``no_dig``) when no cell is
    allowed.

    Args:
        spec: the episode of task ``trench`` (see :func:`~excavsim.envs.core.as_spec`); its seed is the first
            episode's unless reset gives one.
        weights: reward weights over :data:`DIG_WEIGHTS`.
        fallback: see above.
        window_margin_m, window_half_width_m: the observation window (:class:`GoalWindow`) at the
            map's cell size.
        observer: an extra :class:`~excavsim.handoff.episode.EpisodeObserver` (a Rerun recorder, say).
        robot_path, scene_path: base configuration files under the spec's overrides.
    """

    def __init__(self, spec=None, *, weights: Mapping[str, float] | None = None, fallback: bool = True,
                 window_margin_m: float = 0.25, window_half_width_m: float = 0.3,
                 observer: EpisodeObserver | None = None, robot_path=None, scene_path=None):
        self.spec = as_spec(spec, NAME)
        self.resolved = resolve(self.spec, robot_path=robot_path, scene_path=scene_path)
        self.weights = check_weights(weights, DIG_WEIGHTS, "dig")
        self.fallback = bool(fallback)
        self.observer = observer
        self.robot_path, self.scene_path = robot_path, scene_path
        g = self.resolved.planner.grid
        self.action_low = np.array([g.k_min_m, math.radians(g.alpha_min_deg), g.d1_min_m])
        self.action_high = np.array([g.k_max_m, math.radians(g.alpha_max_deg), g.d1_max_m])
        self.window = GoalWindow(self.resolved.goal, self.resolved.sensing.map.cell_size_m, window_margin_m,
                                 window_half_width_m)
        self.fields = {
            "elevation": Field(self.window.shape, "float32", -2.0, 2.0,
                               doc="scanned (believed) map around the goal, relative to the goal's surface [m]"),
            "goal_mask": Field(self.window.shape, "float32", 0.0, 1.0, doc="1 inside the trench's footprint"),
            "goal_depth": Field(self.window.shape, "float32", 0.0, 2.0,
                                doc="depth of the goal profile below its surface [m], 0 outside"),
            "ft": Field((2,), "float32", 0.0, 1e6, doc="last dig's peak and mean F/T force in the soil [N]"),
            "outcome": Field((), "int64", n=len(OUTCOMES), doc="last dig's outcome, an index of OUTCOMES"),
            "digs_left": Field((), "int64", n=self.spec.dig_budget + 1, doc="digs left in the budget"),
        }
        self._episode = None  # a new one per reset: an online learner's memory is one episode's
        self._closed = False
        self._clear()

    action_label = "the dig action (k, alpha, d1)"

    def _clear(self) -> None:
        super()._clear()  # _last: the last dig's metrics, record summary and reward terms
        self._sim = self._rig = self._truth = self._belief = None
        self._planned: Choice | None = None  # the planner's choice of the cycle waiting for the agent
        self._goal_layers = None
        self._measured = (0.0, 0.0)

    # -- the episode, up to the agent's next decision ---------------------------------------------
    def _advance(self) -> _Decision:
        """Cycle the episode up to the next dig that needs the agent's action (the planner's choice
        on the scanned map is made first), or to its end."""
        ep = self._episode
        while not ep.over:
            ep.look()
            self._belief = ep.emap  # also the last look's, when it ended the episode (the final observation)
            if ep.over:
                break
            choice = self._source.choose(self._rig, ep.emap)
            waiting = self._agent_waits(choice)
            if waiting is not None:
                self._planned = choice
                return waiting
            ep.decide(choice)  # the episode goes on (or ends) without the agent
            if not ep.over:
                self._dig()
        return _Decision(emap=self._belief, result=ep.result)

    def _agent_waits(self, choice: Choice) -> _Decision | None:
        """The decision the agent is asked for in this cycle, or None when the cycle needs no action
        (then ``choice`` is dug, or ends the episode, as the loop decides)."""
        plan = choice.plan
        if plan is None:  # the source did not plan (no dig at all): the episode ends as the loop decides
            return None
        planner_dug = plan.action is not None
        if self.fallback and not planner_dug:
            if choice.dig is None:
                return None  # no dig even after the fallback: the episode ends no_dig
            return _Decision(emap=self._belief, planner_action=None, planner_fell_back=True)
        if not self._allowed(plan).any():
            return None  # the agent's choice is replaced by no dig (see _agent_choice)
        return _Decision(emap=self._belief, planner_action=plan.action if planner_dug else None)

    def _allowed(self, plan) -> np.ndarray:
        """The grid cells the agent's action may be dug as: the planner's feasible set less the memory's exclusions."""
        allowed = plan.feasible.copy()
        source = self._source
        if source.experience is not None:
            p = self._rig.planner
            allowed &= ~source.experience.excluded(p.grid_k, p.grid_alpha, p.grid_d1, source.scanned_surface)
        return allowed

    def _agent_choice(self, choice: Choice, action: np.ndarray | None) -> Choice:
        """The dig of this cycle with the agent's ``action`` (None: the cycle did not wait for one)."""
        plan = choice.plan
        if plan is None:
            return choice
        planner_dug = plan.action is not None
        if self.fallback and not planner_dug:
            if choice.dig is not None:
                self._decided = {"action_used": False, "cell": None, "snapped": False}
            return choice
        allowed = self._allowed(plan)
        if not allowed.any():
            return Choice(None, f"no trenching action is feasible on this map ({plan.reason})", plan)
        grids = (plan.grid_k, plan.grid_alpha, plan.grid_d1)
        requested = tuple(int(np.argmin(np.abs(g - v))) for g, v in zip(grids, action))
        cell = requested
        if not allowed[cell]:
            cells = np.argwhere(allowed)
            cell = tuple(int(i) for i in cells[int(np.argmin(((cells - np.array(requested)) ** 2).sum(axis=1)))])
        self._decided = {"action_used": True, "cell": cell, "snapped": cell != requested}
        chosen = tuple(int(np.argmin(np.abs(g - v))) for g, v in zip(grids, plan.action[:3])) if planner_dug else None
        if cell == chosen:
            return choice  # the planner's own dig, exactly as PlannedDigs dug it
        planner = self._rig.planner
        k, alpha, d1 = (float(g[i]) for g, i in zip(grids, cell))
        act = TrenchAction(k, alpha, d1, float(plan.d2[cell]))
        surface = planner.surface(self._belief)
        poses, phases = planner.trajectory(act, surface, radius=float(plan.curl_radius[cell]))
        _, torques = planner.path_loads(poses, phases, surface)
        seconds = choice.dig.planning_s if choice.dig is not None else plan.seconds
        dig = Dig("planned", poses, phases, float(plan.volume[cell]), act, seconds,
                  predicted_peak_nm=np.abs(torques).max(axis=0))
        return Choice(dig, plan=plan, note=choice.note)

    def _dig(self) -> None:
        """Dig the decided dig; after the soil settled, the record's F/T summary and the reward's terms."""
        ep = self._episode
        dug = ep.dig()
        if dug is None:  # the world failed on the way to the dig: nothing was dug
            return
        record, metrics = dug
        lo, hi = record.in_soil_window()
        forces = [np.linalg.norm(f) for t, f in record.ft if lo <= t <= hi]
        removed, over = self._truth.measure()
        d_removed, d_over = removed - self._measured[0], over - self._measured[1]
        self._measured = (removed, over)
        stalled = metrics.stall_joint is not None
        w = self.weights
        terms = {"removed_l": 1000 * d_removed, "overdig_l": 1000 * d_over, "stalled": stalled}
        reward = (w["removed_per_l"] * terms["removed_l"] - w["overdig_per_l"] * terms["overdig_l"]
                  - w["stall"] * stalled)
        self._last = {"metrics": metrics, "ft": (max(forces, default=0.0), float(np.mean(forces)) if forces else 0.0),
                      "terms": terms, "reward": float(reward)}

    # -- the caller's side -------------------------------------------------------------------------
    def _start(self, seed: int) -> None:
        self._episode = ep = spec_episode(self.spec, self.resolved, observer=self.observer)
        self._source = _AgentDigs(DigExperience() if self.spec.options.memory else None)
        ep.reset(seed, digs=self._source)
        task = ep.task
        self._sim, self._rig = task.sim, task.rig
        self._truth = TrueTrench(task.sim, task.mask, task.z_goal)

    def _agent_choice_for(self, action: np.ndarray) -> Choice:
        return self._agent_choice(self._planned, action)

    def _observation(self) -> dict[str, np.ndarray]:
        if self._goal_layers is None:
            self._goal_layers = self.window.goal_layers(self._rig.width)
        mask, depth = self._goal_layers
        elevation = (self.window.elevation(self._belief) if self._belief is not None  # None: the world broke
                     else np.zeros(self.window.shape, np.float32))                 # before the first scan
        last = self._last or {}
        m = last.get("metrics")
        digs_left = self.spec.dig_budget - (len(self.result.digs) if self.result is not None else self.digs)
        return {"elevation": elevation, "goal_mask": mask.copy(), "goal_depth": depth.copy(),
                "ft": np.array(last.get("ft", (0.0, 0.0)), dtype=np.float32),
                "outcome": np.int64(outcome_index(m.outcome if m is not None else None)),
                "digs_left": np.int64(max(digs_left, 0))}

    def _info(self, decision: _Decision, first: bool = False) -> dict[str, Any]:
        info: dict[str, Any] = {
            "planner_action": (None if decision.planner_action is None
                               else np.array(decision.planner_action[:3], dtype=np.float64)),
            "planner_fell_back": bool(decision.planner_fell_back),
        }
        emap = decision.emap if decision.emap is not None else self._belief
        if emap is not None and self._rig is not None:
            r = self.resolved
            done, frac = map_done(emap, r.goal, self._rig.arm, self._rig.width, done_fraction=self.spec.options.done_fraction,
                                  tolerance_m=self.spec.options.tolerance_m, initial_z=r.goal.surface_z_m)
            info["map_removed_fraction"] = float(frac)
        if not first and self._last is not None:
            m = self._last["metrics"]
            row = dig_rows(_Digs([m]), self.spec.task)[0]
            row = {k: (None if isinstance(v, float) and math.isnan(v) else v) for k, v in row.items()}
            row["efficiency"] = float(m.efficiency) if math.isfinite(m.efficiency) else None
            info["dig"] = row
            info["reward_terms"] = dict(self._last["terms"])
            decided = self._decided or {}
            info["action_used"] = bool(decided.get("action_used", False))
            cell = decided.get("cell")
            info["executed_cell"] = None if cell is None else np.array(cell, dtype=np.int64)
            info["snapped_to_allowed"] = bool(decided.get("snapped", False))
        if decision.result is not None:
            summary = episode_summary(decision.result, self.spec.task)
            info["episode"] = {k: (None if isinstance(v, float) and math.isnan(v) else v)
                               for k, v in summary.items() if k not in TIMING_KEYS}
        return info


class _Digs:
    """The one attribute of an episode result that :func:`~excavsim.loop.scenario.dig_rows` reads."""

    def __init__(self, digs):
        self.digs = digs
