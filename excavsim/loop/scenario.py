"""Episode specifications: one trenching episode as data, shared by ``trench``, ``campaign`` and ``regress``.

An :class:`EpisodeSpec` names the trench goal, the soil, the seed, the stopping rules and
overrides of any configuration file (robot, scene, planner, executor, sensing), written as nested
mappings merged over the defaults in ``configs/``. For example, a weaker wrist and a coarser
planner grid::

    name: weak-wrist
    soil: lean_clay
    seed: 3
    robot: {joints: {wrist_pitch: {torque_limit_nm: 500}}}
    planner: {grid: {k_step_m: 0.2}}

:func:`spec_episode` makes its :class:`~excavsim.loop.episode.Episode`, :func:`run_spec` builds the
world and runs it; :func:`episode_summary` flattens the result
into a JSON-ready dict of numbers (the row a campaign writes and ``regress`` compares).
"""

from __future__ import annotations

import copy
import math
import pathlib
import re
from collections.abc import Callable
from typing import Any

from pydantic import Field, model_validator

from excavsim import constants
from excavsim.config import (ConfigError, ExecutorConfig, PlannerConfig, RobotConfig, SceneConfig, SensingConfig,
                             StrictModel, TrenchGoal, get_soil, load_config, load_executor_config, load_planner_config,
                             load_robot_config, load_scene_config, load_sensing_config, load_trench_goal,
                             parse_config)
from excavsim.config.semantic import check_goal
from excavsim.errors import shorten


class EpisodeSpec(StrictModel):
    """One trenching episode: goal, soil, seed, stopping rules and configuration overrides."""

    name: str = Field(default="episode", description="label for logs and result files")
    goal: str | TrenchGoal = Field(
        default="sand", description="a trench of configs/trenches (by name), a YAML path, or the goal inline")
    soil: str | None = Field(default=None, description="soil preset of configs/soils.yaml (default: the scene's)")
    seed: int = Field(default=0, ge=0, le=2**32 - 1, description="episode seed (soil, sensor noise, scanner drift)")
    dig_budget: int = Field(default=20, ge=1, le=1000, description="most digs to try")
    done_fraction: float = Field(default=0.95, gt=0, le=1, description="goal volume fraction that counts as done")
    tolerance_m: float = Field(default=0.03, gt=0, le=1, description="no map cell may stay this far above the goal")
    robot: dict[str, Any] = Field(default_factory=dict, description="overrides of configs/robot.yaml")
    scene: dict[str, Any] = Field(default_factory=dict, description="overrides of configs/scene.yaml")
    planner: dict[str, Any] = Field(default_factory=dict, description="overrides of configs/planner.yaml")
    executor: dict[str, Any] = Field(default_factory=dict, description="overrides of configs/executor.yaml")
    sensing: dict[str, Any] = Field(default_factory=dict, description="overrides of configs/sensing.yaml")
    memory: bool = Field(
        default=True, description="remember failed digs and where digs found no soil, and plan around them "
                                  "(excavsim.planning.experience); false plans every dig afresh, as the thesis")
    predictor: str = Field(
        default="wedge", description="the planner's force predictor: wedge (nominal, eq. 8) or a learning method "
                                     "of excavsim.learning.predictors.METHODS, learned online from this episode's digs")

    @model_validator(mode="after")
    def _check(self) -> EpisodeSpec:
        if self.soil is not None:
            get_soil(self.soil)  # raises with the allowed names
        if self.predictor != "wedge":
            from excavsim.learning.predictors import METHODS

            if self.predictor not in METHODS:
                raise ConfigError(f"unknown predictor {self.predictor!r}; allowed: wedge, {', '.join(METHODS)}")
        return self


def merge(base: dict, overrides: dict, *, where: str = "") -> dict:
    """``base`` with ``overrides`` merged in, recursively for nested mappings (a new dict).

    Raises:
        ConfigError: an override names a mapping field with a non-mapping value.
    """
    out = copy.deepcopy(base)
    for key, value in overrides.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = merge(out[key], value, where=f"{where}{key}.")
        else:
            if isinstance(out.get(key), dict):
                raise ConfigError(f"override {where}{key}: expected a mapping of fields, got {value!r}")
            out[key] = value
    return out


def _override(base, overrides: dict, model, label: str):
    if not overrides:
        return base
    return parse_config(merge(base.model_dump(), overrides), model, source=f"{label} overrides")


def load_spec(path: str | pathlib.Path) -> EpisodeSpec:
    """Read and validate an episode specification YAML file."""
    return load_config(path, EpisodeSpec)


def resolve_goal(goal: str | TrenchGoal) -> TrenchGoal:
    """A goal given by name (configs/trenches/NAME.yaml), by path, or inline."""
    if isinstance(goal, TrenchGoal):
        return goal
    path = pathlib.Path(goal)
    if path.suffix not in (".yaml", ".yml"):
        path = constants.TRENCHES_DIR / f"{goal}.yaml"
        if not re.fullmatch(r"[A-Za-z0-9_.-]{1,100}", goal) or not path.is_file():
            names = sorted(p.stem for p in constants.TRENCHES_DIR.glob("*.yaml"))
            raise ConfigError(f"unknown trench goal {shorten(repr(goal))}; give a YAML path or one of: "
                              f"{', '.join(names)}")
    return load_trench_goal(path)


class ResolvedSpec:
    """The configurations an :class:`EpisodeSpec` stands for, with every override applied."""

    def __init__(self, spec: EpisodeSpec, *, robot_path: str | pathlib.Path | None = None,
                 scene_path: str | pathlib.Path | None = None):
        self.spec = spec
        self.goal: TrenchGoal = resolve_goal(spec.goal)
        self.robot: RobotConfig = _override(load_robot_config(robot_path), spec.robot, RobotConfig,
                                            f"{spec.name}: robot")
        scene = _override(load_scene_config(scene_path), spec.scene, SceneConfig, f"{spec.name}: scene")
        self.scene: SceneConfig = scene.model_copy(update={"soil": spec.soil}) if spec.soil else scene
        named = f" {shorten(spec.goal, 200)}" if isinstance(spec.goal, str) else ""
        check_goal(self.goal, self.scene, source=f"{spec.name}: goal{named}")
        self.planner: PlannerConfig = _override(load_planner_config(), spec.planner, PlannerConfig,
                                                f"{spec.name}: planner")
        self.executor: ExecutorConfig = _override(load_executor_config(), spec.executor, ExecutorConfig,
                                                  f"{spec.name}: executor")
        self.sensing: SensingConfig = _override(load_sensing_config(), spec.sensing, SensingConfig,
                                                f"{spec.name}: sensing")


def spec_episode(spec: EpisodeSpec, resolved: ResolvedSpec | None = None, *,
                 progress: Callable[[str], None] | None = None, observer=None):
    """The :class:`~excavsim.loop.episode.Episode` of ``spec`` (not yet reset): its goal, stopping
    rules and configurations, and its observers (with the online learner of ``spec.predictor``).

    Args:
        resolved: ``spec``'s configurations (default: resolved here from ``configs/``).
    """
    from excavsim.handoff.episode import ObserverGroup
    from excavsim.loop.episode import Episode

    r = resolved or ResolvedSpec(spec)
    if spec.predictor != "wedge":  # learned online, from scratch, from this episode's digs (§5.2)
        from excavsim.loop.online import OnlineLearning

        observer = ObserverGroup(OnlineLearning(spec.predictor, progress=progress), observer)
    return Episode(goal=r.goal, dig_budget=spec.dig_budget, done_fraction=spec.done_fraction,
                   tolerance_m=spec.tolerance_m, planner_cfg=r.planner, executor_cfg=r.executor,
                   sensing_cfg=r.sensing, robot_cfg=r.robot, scene_cfg=r.scene, progress=progress,
                   observer=observer)


def spec_digs(spec: EpisodeSpec):
    """The dig source of ``spec``: the planner, with the memory of failed digs when ``spec.memory``."""
    from excavsim.loop.digs import PlannedDigs
    from excavsim.planning.experience import DigExperience

    return PlannedDigs(DigExperience() if spec.memory else None)


def run_spec(spec: EpisodeSpec, *, progress: Callable[[str], None] | None = None, observer=None,
             robot_path: str | pathlib.Path | None = None, scene_path: str | pathlib.Path | None = None):
    """Build the world of ``spec`` and run its episode; returns the
    :class:`~excavsim.loop.episode.EpisodeResult`.

    Args:
        robot_path, scene_path: base configuration files the spec's overrides apply to (default
            configs/robot.yaml and configs/scene.yaml).
    """
    r = ResolvedSpec(spec, robot_path=robot_path, scene_path=scene_path)
    episode = spec_episode(spec, r, progress=progress, observer=observer)
    episode.reset(spec.seed, digs=spec_digs(spec))
    return episode.run()


def dig_rows(res) -> list[dict[str, Any]]:
    """One JSON-ready row per dig of an episode: its action (NaN for a fallback dig), volumes [l],
    outcome and failure, and the predicted and measured peak wrist-pitch torques [N m]."""
    rows = []
    for d in res.digs:
        k, a, d1, d2 = d.action if d.action is not None else (math.nan,) * 4
        rows.append({"dig": d.index, "kind": d.kind, "k_m": k, "alpha_deg": math.degrees(a), "d1_m": d1, "d2_m": d2,
                     "planned_l": 1000 * d.predicted_m3, "dug_l": 1000 * d.bucket_m3, "outcome": d.outcome,
                     "failure": d.failure or "", "stall_joint": d.stall_joint or "",
                     "wrist_predicted_nm": float(d.predicted_peak_nm[2]),
                     "wrist_measured_nm": float(d.peak_torque_nm[3])})
    return rows


def episode_summary(res) -> dict[str, Any]:
    """The episode's metrics as a flat dict of JSON numbers and strings (one campaign row).

    Per-dig lists are reduced to totals, means and peaks; ``end`` is the stopping rule that fired
    (``done``, ``no_dig``, ``budget``, ``diverged`` or ``timeout``), ``reason`` its full text;
    ``diverged_digs`` counts the digs in which the simulation diverged (at most one: the episode ends there).
    """
    digs = res.digs
    n = len(digs)
    peaks = [d.peak_torque_nm for d in digs]
    joints = ("waist", "shoulder", "elbow", "wrist_pitch", "wrist_yaw", "wrist_roll")
    out: dict[str, Any] = {
        "end": res.end, "reason": res.reason, "digs": n, "fallback_digs": sum(d.kind != "planned" for d in digs),
        "stalls": sum(d.stall_joint is not None for d in digs),
        "failed_digs": sum(d.failed for d in digs), "failed_fraction": sum(d.failed for d in digs) / n if n else 0.0,
        "no_contact_digs": sum(d.outcome == "no contact" for d in digs),
        "diverged_digs": sum(d.outcome == "diverged" for d in digs),
        "little_soil_digs": sum(d.outcome != "no contact" and d.stall_joint is None and not d.bucket_m3 >= 0.001
                                for d in digs),
        "goal_l": 1000 * res.goal_m3, "removed_l": 1000 * res.removed_m3, "removed_fraction": res.removed_fraction,
        "dug_l_per_dig": 1000 * sum(d.bucket_m3 for d in digs) / n if n else 0.0,
        "planned_l_per_dig": 1000 * sum(d.predicted_m3 for d in digs) / n if n else 0.0,
        "efficiency": sum(d.efficiency for d in digs) / n if n else 0.0,
        "overdig_max_cm": 100 * res.overdig_max_m, "overdig_rms_cm": 100 * res.overdig_rms_m,
        "underdig_max_cm": 100 * res.underdig_max_m, "underdig_rms_cm": 100 * res.underdig_rms_m,
        "planning_s": sum(d.planning_s for d in digs), "sim_s": res.sim_time_s, "wall_s": res.wall_time_s,
        "cumulative_torque_knm_s": sum(d.cumulative_torque_nm_s for d in digs) / 1000,
        "volume_change_m3": res.volume_change_m3,
    }
    for j, name in enumerate(joints[1:4], start=1):
        out[f"peak_{name}_nm"] = max((float(p[j]) for p in peaks), default=0.0)
    out["dug_l"] = [round(1000 * d.bucket_m3, 3) for d in digs]
    return out
