"""The loading environment's core: loading from a pile in MuJoCo one dig at a time, free of any RL library.

:class:`LoadCore` steps the platform's :class:`~excavsim.loop.episode.Episode` of a
:class:`~excavsim.tasks.pile_loading.task.LoadTask` (what ``excavsim run`` runs for ``task:
pile_loading``) phase by phase, with the agent's loading action in place of the loading planner's choice
(:func:`excavsim.tasks.pile_loading.mind.planner.plan`, Singh 1995 §3.5, §4.1-4.2). Each cycle the task scans the
lane, reads the map's three sections and plans on them (the done test: no dig of minimal utility on
any section); the agent's (k, alpha) (and r with ``parameterization: k_alpha_r``) is snapped to the
planner's grid, replaced by the nearest feasible cell of the planner's search when it is infeasible,
and dug with that cell's maximal d1 and its radius, on the section and from the base the planner
chose; the script digs, dumps and returns, and the lane settles. When the agent's cell is the
planner's, the planner's dig is dug as it is, so the planner used as a policy reproduces the plain
loading episode dig for dig.

Observations are what the machine senses (the scanned map's sections, its joint encoders, the
planner's reference on the map); rewards are measured on the truth (the world's volume account:
soil delivered at the truck, soil spilled off the lane). The Gymnasium face is
:mod:`excavsim.tasks.pile_loading.envs.dig_env`, the dm_env face :mod:`excavsim.tasks.pile_loading.envs.dm`.
"""

from __future__ import annotations

import dataclasses
import math
import pathlib
from collections.abc import Mapping
from typing import Any

import numpy as np

from excavsim.config import parse_config
from excavsim.envs.core import DigLevelCore, Field, check_weights
from excavsim.errors import ConfigError, EnvError
from excavsim.loop.digs import Choice
from excavsim.loop.episode import Episode
from excavsim.loop.scenario import EpisodeSpec, load_spec, resolve
from excavsim.tasks.pile_loading.mind import planner as lp
from excavsim.tasks.pile_loading import planar as ld
from excavsim.tasks.pile_loading.config_planar import LoadingConfig, load_loading_config
from excavsim.tasks.pile_loading.plugin import NAME
from excavsim.tasks.pile_loading.task import SECTIONS, LoadTask, map_sections
from excavsim.tasks.pile_loading.task import summary as loading_summary

LANE_LENGTH_M = 8.5  # models/pile_box: the lane runs from x = 0 to 8.5 m
PROFILE_STEP_M = 0.05
PROFILE_X = PROFILE_STEP_M * (np.arange(int(round(LANE_LENGTH_M / PROFILE_STEP_M))) + 0.5)
"""Where the observation samples the map's sections [m along the lane]: every 5 cm (170 points)."""
MAX_HEIGHT_M = 3.0  # a pile is at most 2.2 m high (PileLane); map noise above this is clipped
JOINT_BOUND = 30.0  # the joints' encoders [m, rad]: the loader's travel is within +-30 m, the angles within +-pi
LOAD_WEIGHTS = {"delivered_per_l": 0.01, "spilled_per_l": 0.01, "dig": 1.0}
"""The loading environment's default reward weights: per litre delivered at the truck, per litre spilled
off the lane, per dig executed (a cycle's time: the cost of 100 l delivered)."""
TIMING_KEYS = ("wall_s",)  # wall-clock numbers left out of ``info`` (they differ run to run)
DEFAULT_SPEC = {"name": "load", "task": NAME}


def as_load_spec(spec: EpisodeSpec | Mapping | str | pathlib.Path | None) -> EpisodeSpec:
    """An :class:`~excavsim.loop.scenario.EpisodeSpec` of task ``pile_loading`` from itself, a mapping of its
    fields (``task`` defaults to ``pile_loading``), a YAML path, or None (the front loader on the pile of
    ``configs/pile_loading.yaml``, 20 digs, seed 0).

    Raises:
        EnvError: the spec is not of task pile_loading, or not a specification at all (with the reason).
    """
    try:
        if spec is None:
            spec = parse_config(dict(DEFAULT_SPEC), EpisodeSpec, source="the environment's spec")
        elif isinstance(spec, Mapping):
            spec = parse_config({"task": NAME, **dict(spec)}, EpisodeSpec, source="the environment's spec")
        elif isinstance(spec, (str, pathlib.Path)):
            spec = load_spec(spec)
    except ConfigError as exc:
        raise EnvError(f"LoadDig-v0: invalid spec: {exc}") from None
    if not isinstance(spec, EpisodeSpec):
        raise EnvError(f"LoadDig-v0: spec must be an EpisodeSpec, a mapping of its fields, a YAML path or None; "
                       f"given {type(spec).__name__}")
    if spec.task != NAME:
        theirs = ", ".join(env.id for env in spec.plugin.environments) or "none"
        raise EnvError(f"LoadDig-v0 loads from a pile: its spec's task must be {NAME!r} (machine loader or shovel); "
                       f"given task {spec.task!r} (its environments: {theirs})")
    return spec


@dataclasses.dataclass
class _Decision:
    """Where the episode stands for the agent: the cycle's plan waiting for the agent's action, or the result."""

    plan: lp.LoadingPlan | None = None
    result: Any = None


class LoadCore(DigLevelCore):
    """A loading episode in MuJoCo, one step per dig (see the module docstring; the stepping is
    :class:`~excavsim.envs.core.DigLevelCore`'s, shared with every task's dig-level core).

    The action is the loading planner's independent variables: (k, alpha) [m, rad] with
    ``parameterization: k_alpha`` (configs/pile_loading_planar.yaml; d1 maximized, r the smallest reachable
    radius), (k, alpha, r) with ``k_alpha_r``; the box is the planner's grid's extent. It is snapped
    to the nearest grid cell; when that cell is infeasible on the cycle's section (no d1 meets every
    constraint of §4.1-4.2), the nearest feasible cell (in grid steps) is dug instead
    (``info["snapped_to_allowed"]``).

    Reward per dig (truth, :class:`~excavsim.tasks.pile_loading.task.SoilAccount`):
    ``delivered_per_l`` x litres the bucket poured at the truck, less ``spilled_per_l`` x litres
    that left the lane otherwise (pushed over its ends or sides), less ``dig`` per executed dig.

    Args:
        spec: the episode (see :func:`as_load_spec`); its seed is the first episode's unless reset
            gives one; its ``dig_budget`` truncates.
        weights: reward weights over :data:`LOAD_WEIGHTS`.
        observer: a :class:`~excavsim.tasks.pile_loading.task.LoadingObserver` (a Rerun recorder, say).
        loading_config: the machines' numbers and the planner's grid and rules
            (:class:`~excavsim.tasks.pile_loading.config_planar.LoadingConfig` or its YAML path; default
            ``configs/pile_loading_planar.yaml``, as ``excavsim run`` uses); the action box is its grid's.
    """

    def __init__(self, spec=None, *, weights: Mapping[str, float] | None = None, observer=None,
                 loading_config: LoadingConfig | str | pathlib.Path | None = None):
        self.spec = as_load_spec(spec)
        self.resolved = resolve(self.spec)
        self.weights = check_weights(weights, LOAD_WEIGHTS, "loading")
        self.observer = observer
        if loading_config is None or isinstance(loading_config, (str, pathlib.Path)):
            loading_config = load_loading_config(loading_config)
        elif not isinstance(loading_config, LoadingConfig):
            raise EnvError(f"loading_config must be a LoadingConfig, a YAML path or None; given "
                           f"{type(loading_config).__name__}")
        self.cfg2d = cfg2d = loading_config
        self.rules = rules = ld.make_rules(cfg2d, getattr(cfg2d.machines, self.spec.machine_name).capacity_units)
        gk, ga, gr, _ = rules.grid()
        self.with_radius = rules.parameterization == "k_alpha_r"
        low, high = [gk[0], ga[0]], [gk[-1], ga[-1]]
        if self.with_radius:
            low.append(gr.min())
            high.append(gr.max())
        self.action_low, self.action_high = np.array(low), np.array(high)
        self.action_names = ("k", "alpha", "r") if self.with_radius else ("k", "alpha")
        n_joints = 4 if self.spec.machine_name == "shovel" else 3
        self.fields = {
            "sections": Field((len(SECTIONS), PROFILE_X.size), "float32", 0.0, MAX_HEIGHT_M,
                              doc="scanned (believed) heights of the map's sections (middle, near side, far side) "
                                  "every 5 cm along the lane from x = 0.025 m [m above the ground]"),
            "joints": Field((n_joints,), "float32", -JOINT_BOUND, JOINT_BOUND,
                            doc="joint encoders: the loader's travel [m], boom, bucket [rad]; the shovel's base "
                                "[m], boom, stick, bucket [rad]"),
            "reference": Field((2,), "float32", -JOINT_BOUND, JOINT_BOUND,
                               doc="the cycle's foot on the map that k is measured from and the shovel's planned "
                                   "base x (0 for the loader) [m]"),
            "section": Field((), "int64", n=len(SECTIONS), doc="the section the cycle digs, an index of SECTIONS"),
            "digs_left": Field((), "int64", n=self.spec.dig_budget + 1, doc="digs left in the budget"),
        }
        self._episode = None
        self._closed = False
        self._clear()

    def _clear(self) -> None:
        super()._clear()  # _last: the last dig and its reward's terms
        self._task = None

    @property
    def action_label(self) -> str:
        return f"the loading action ({', '.join(self.action_names)})"

    # -- the episode, up to the agent's next decision -----------------------------------------------------
    def _advance(self) -> _Decision:
        """Look (scan, sections, the planner's plan: the done test); the cycle's plan or the episode's end."""
        ep = self._episode
        if not ep.over:
            ep.look()
        if ep.over:
            return _Decision(result=ep.result)
        return _Decision(plan=self._task.plan)

    def _agent_choice(self, plan: lp.LoadingPlan, action: np.ndarray) -> Choice:
        """The cycle's dig with the agent's ``action``: the planner's own when it falls on its cell."""
        task = self._task
        allowed = np.isfinite(plan.d1)
        grids = (plan.grid_k, plan.grid_alpha) + ((plan.grid_r,) if self.with_radius else ())
        requested = tuple(int(np.argmin(np.abs(g - v))) for g, v in zip(grids, action))
        if not self.with_radius:
            requested += (0,)
        cell = requested
        if not allowed[cell]:
            cells = np.argwhere(allowed)
            cell = tuple(int(i) for i in cells[int(np.argmin(((cells - np.array(requested)) ** 2).sum(axis=1)))])
        a = plan.action
        chosen = (int(np.argmin(np.abs(plan.grid_k - a.k))), int(np.argmin(np.abs(plan.grid_alpha - a.alpha))),
                  int(np.argmin(np.abs(plan.grid_r - a.r))) if self.with_radius else 0)
        self._decided = {"cell": cell, "snapped": cell != requested, "planner_cell": cell == chosen}
        if cell != chosen:
            ik, ia, ir = cell
            act = lp.LoadingAction(float(plan.grid_k[ik]), float(plan.grid_alpha[ia]), float(plan.d1[cell]),
                                   float(plan.cell_r[cell]), a.foot, float(plan.entry_h[ik]))
            task.plan = dataclasses.replace(plan, action=act, volume=float(plan.cell_volume[cell]),
                                            force=float(plan.cell_force[cell]), reason="the agent's action")
        return task.choose(self._episode.emap)

    def _dig(self) -> None:
        """Dig the decided dig (dig, dump, return, settle); the reward's terms from the volume account."""
        dug = self._episode.dig()
        if dug is None:  # the world failed on the way: nothing was dug
            return
        dig, = dug
        w = self.weights
        terms = {"delivered_l": 1000 * float(dig.delivered_m3), "spilled_l": 1000 * float(dig.spilled_m3), "dig": 1}
        reward = (w["delivered_per_l"] * terms["delivered_l"] - w["spilled_per_l"] * terms["spilled_l"]
                  - w["dig"] * terms["dig"])
        self._last = {"dig": dig, "terms": terms, "reward": float(reward)}

    # -- the caller's side ----------------------------------------------------------------------------------
    def _start(self, seed: int) -> None:
        spec = self.spec  # the episode of excavsim.loop.scenario.spec_episode, with this 2-D configuration
        task = LoadTask(spec.machine_name, cfg=self.resolved, cfg2d=self.cfg2d)
        self._episode = ep = Episode(task, dig_budget=spec.dig_budget, observer=self.observer)
        ep.reset(seed)
        self._task = ep.task

    def _agent_choice_for(self, action: np.ndarray) -> Choice:
        return self._agent_choice(self._pending.plan, action)

    def _observation(self) -> dict[str, np.ndarray]:
        task, emap = self._task, self._episode.emap
        sections = np.zeros(self.fields["sections"].shape, np.float32)
        if emap is not None:
            found = map_sections(emap, task.cfg.section_half_width)
            for i, name in enumerate(SECTIONS):
                terrain = found.get(name, found["middle"])
                sections[i] = np.clip(terrain.surface(PROFILE_X), 0.0, MAX_HEIGHT_M)
        plan = self._pending.plan if self._pending is not None else None
        reference = np.zeros(2, np.float32)
        section = 0
        if plan is not None:
            reference[0] = plan.action.foot
            reference[1] = plan.base_x if math.isfinite(plan.base_x) else 0.0
            section = SECTIONS.index(task.section)
        joints = np.clip(np.asarray(task.q, dtype=np.float32), -JOINT_BOUND, JOINT_BOUND)
        digs_left = self.spec.dig_budget - (len(self.result.digs) if self.result is not None else self.digs)
        return {"sections": sections, "joints": joints, "reference": np.clip(reference, -JOINT_BOUND, JOINT_BOUND),
                "section": np.int64(section), "digs_left": np.int64(max(digs_left, 0))}

    def _info(self, decision: _Decision, first: bool = False) -> dict[str, Any]:
        task = self._task
        plan = decision.plan
        info: dict[str, Any] = {"planner_action": None, "planner_section": None,
                                "map_soil_m3": float(task.map_end) if math.isfinite(task.map_end) else None}
        if plan is not None:
            a = plan.action
            info["planner_action"] = np.array([a.k, a.alpha] + ([a.r] if self.with_radius else []), np.float64)
            info["planner_section"] = task.section
        if not first and self._last is not None:
            d = self._last["dig"]
            a = d.action
            info["dig"] = {"k": a.k, "h": a.h, "alpha": a.alpha, "d1": a.d1, "r": a.r, "foot": a.foot,
                           "base_x": None if not math.isfinite(d.base_x) else d.base_x, "section": d.section,
                           "planned_m3": float(d.planned_m3), "bucket_m3": float(d.bucket_m3),
                           "delivered_m3": float(d.delivered_m3),
                           "spilled_m3": float(d.spilled_m3), "lane_m3": float(d.lane_m3)}
            info["reward_terms"] = dict(self._last["terms"])
        if not first and self._decided is not None:
            info["executed_cell"] = np.array(self._decided["cell"], dtype=np.int64)
            info["snapped_to_allowed"] = bool(self._decided["snapped"])
            info["planner_cell"] = bool(self._decided["planner_cell"])
        if decision.result is not None:
            summary = loading_summary(decision.result)
            info["episode"] = {k: (None if isinstance(v, float) and math.isnan(v) else v)
                               for k, v in summary.items() if k not in TIMING_KEYS}
        return info
