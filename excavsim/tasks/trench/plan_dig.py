"""``excavsim plan``: plan one dig of a trench on an elevation map, outside any episode, and say why.

The planner is the loop's (:func:`~excavsim.rig.core.make_planner`), built from the compiled scene
model without a world: the arm, the bucket's width and capacity come from the model, the torque
limits from the robot configuration, the nominal force predictor from a soil preset.
"""

from __future__ import annotations

import math
import pathlib
import time
from collections.abc import Callable

import mujoco
import numpy as np

from excavsim import constants
from excavsim.config import check_goal, get_soil, load_planner_config, load_robot_config, load_scene_config
from excavsim.errors import shorten
from excavsim.handoff.goal import SurfaceProfile
from excavsim.handoff.maps import ElevationMap
from excavsim.rig.core import make_planner
from excavsim.tasks.trench.spec import resolve_goal
from excavsim.robot.extract import arm_from_model
from excavsim.robot import reachability


def flat_fill_map() -> ElevationMap:
    """The soil box of models/soil_box (3 m square from x = 0.55 m), flat at the 0.5 m fill."""
    return ElevationMap(0.55, -1.5, 0.05, np.full((60, 60), 0.5), np.ones((60, 60), bool), 0.0)


def _force_limited_where(result) -> str:
    """Where the force-limited cells of ``result`` lie (Fig. 87: steep alpha, long d1): their mean
    alpha and d1 beside those of the feasible cells the geometry limits; empty if there are none."""
    lim = result.limiting
    force = (result.feasible & (lim == 3)) | (~result.feasible & (lim == 2))
    geometric = result.feasible & ~force
    if not force.any() or not geometric.any():
        return ""
    alpha = np.degrees(np.broadcast_to(result.grid_alpha[None, :, None], force.shape))
    d1 = np.broadcast_to(result.grid_d1[None, None, :], force.shape)
    return (f"at alpha {alpha[force].mean():.0f} deg, d1 {d1[force].mean():.2f} m on average (the geometry-limited: "
            f"alpha {alpha[geometric].mean():.0f} deg, d1 {d1[geometric].mean():.2f} m)")


def plan_on_map(*, goal: str | None = None, map_path: str | None = None, planner_config: str | None = None,
                robot_config: str | None = None, soil: str = "testbed_sand", wrist_limit: float | None = None,
                volume_constraint: bool = True, figures_dir: str | pathlib.Path | None = None,
                say: Callable[[str], None] = print) -> None:
    """Plan one dig and say the action, its objective, volume, peak torques, the feasible cells and
    the planning time; with ``figures_dir``, draw the feasible sets, the limiting constraints and the
    dig there (Figs. 85-87).

    Args:
        goal: a trench name of ``configs/trenches`` or a YAML file (default ``straight``).
        map_path: an elevation map written by excavsim (default: the flat 0.5 m fill).
        planner_config, robot_config: configuration files (default ``configs/``).
        soil: the soil preset the force predictor assumes.
        wrist_limit: the wrist pitch torque limit [N m] (default: the robot configuration's).
        volume_constraint: False switches the volume constraint off (§7.2.2, Figs. 115-117).
        figures_dir: where the figures go; None: no figures, and the pruned search the loop uses.
        say: where the lines go.
    """
    trench = resolve_goal(goal or "straight")
    check_goal(trench, load_scene_config(), source=f"--goal {shorten(goal or 'straight')}")
    config = load_planner_config(planner_config)
    if not volume_constraint:
        config = config.model_copy(update={"volume_constraint": False})
    robot = load_robot_config(robot_config)
    nominal = get_soil(soil)
    if map_path:
        emap, map_label = ElevationMap.load(map_path), map_path
    else:
        emap, map_label = flat_fill_map(), "flat 0.5 m fill"
    joints = robot.joints
    wrist = joints.wrist_pitch.torque_limit_nm if wrist_limit is None else wrist_limit
    limits = np.array([joints.shoulder.torque_limit_nm, joints.elbow.torque_limit_nm, wrist])

    model = mujoco.MjModel.from_xml_path(str(constants.SCENE_XML))
    arm = arm_from_model(model)
    width = float(model.numeric(constants.BUCKET_WIDTH_NUMERIC).data[0])
    capacity = float(model.numeric(constants.BUCKET_CAPACITY_NUMERIC).data[0])
    volume_rule = (f"volume <= {config.fill_fraction:g} x capacity" if config.volume_constraint
                   else "volume constraint off")
    say(f"excavsim plan: trench {trench.name or goal!r} on {map_label}, soil {soil}, wrist {wrist:.0f} N m, "
        f"objective {config.objective}, {volume_rule}")
    t0 = time.perf_counter()
    table = reachability.load_or_build(arm)  # built and cached on first use (a few seconds)
    t_table = time.perf_counter() - t0
    planner = make_planner(arm, limits, width, capacity, trench, config, nominal, table=table)
    # The figures show every constraint's set over the whole grid, so they need the unpruned search
    # (same answer, slower); without figures the planner searches as the loop does.
    figures = figures_dir is not None
    result = planner.plan(emap, prune=not figures, classify_limits=True)

    rows = []
    if result.action is None:
        rows.append(("action", f"none: {result.reason}"))
    else:
        k, alpha, d1, d2 = result.action
        rows.append(("action", f"k {k:.2f} m   alpha {math.degrees(alpha):.1f} deg   d1 {d1:.3f} m   d2 {d2:.3f} m"))
        rows.append(("objective", f"{result.reason} (utility {result.utility:.3f})"))
        rows.append(("volume", f"{1000 * result.volume_m3:.1f} l of {1000 * capacity:.1f} l capacity "
                               f"({100 * result.volume_m3 / capacity:.0f} %)"))
        peaks = np.abs(result.torques).max(axis=0)
        for name, peak, limit in zip(("shoulder", "elbow", "wrist pitch"), peaks, limits):
            rows.append((f"torque {name}", f"peak {peak:7.0f} N m of {limit:7.0f} N m ({100 * peak / limit:3.0f} %)"))
    counts = result.counts
    lim = result.limiting
    n_short, n_none = int(np.sum(result.feasible & (lim == 3))), int(np.sum(~result.feasible & (lim == 2)))
    rows.append(("cells", f"{int(result.feasible.sum())} feasible of {counts['cells']}; evaluated "
                          f"{counts['evaluated']}, pruned along d1 {counts['pruned_d1']}"))
    rows.append(("force-limited", f"{n_short + n_none} cells (Fig. 87): {n_short} feasible with the drag cut short "
                                  f"by the torque limits, {n_none} with no drag within them"))
    where = _force_limited_where(result)
    if where:
        rows.append(("", where))
    if config.volume_constraint:
        # Chapter 5's setting of Fig. 87: the force constraint in the volume constraint's place (§4.1.2)
        free_cfg = config.model_copy(update={"volume_constraint": False})
        free = make_planner(arm, limits, width, capacity, trench, free_cfg, nominal, table=table).plan(
            emap, classify_limits=True)
        lim_free = free.limiting
        n_free = int(np.sum(free.feasible & (lim_free == 3)) + np.sum(~free.feasible & (lim_free == 2)))
        rows.append(("  no volume limit", f"{n_free} cells force-limited with the volume constraint off (Chapter 5's "
                                          "setting of Fig. 87, --no-volume-constraint)"))
        where = _force_limited_where(free)
        if where:
            rows.append(("", where))
    search = "unpruned: every constraint on every cell, for the figures" if figures else "pruned search"
    rows.append(("time", f"planning {result.seconds:.2f} s ({search}); reachability table {t_table:.1f} s"))
    width_col = max(len(r[0]) for r in rows)
    for label, text in rows:
        say(f"  {label:<{width_col}}  {text}")

    if figures:
        from excavsim.planning import figures as plots

        out = pathlib.Path(figures_dir)
        paths = [plots.plot_feasible_sets(result, out / "feasible_sets.png",
                                          min_volume_m3=config.volume_threshold * capacity),
                 plots.plot_limits(result, out / "limits.png")]
        if result.action is not None:
            surface = SurfaceProfile.from_map(emap, arm, math.radians(trench.waist_deg), width)
            paths.append(plots.plot_dig(result, trench, surface, out / "dig.png", torque_limits_nm=limits))
        else:
            say("  (no dig chosen: no dig figure)")
        say("figures:")
        for p in paths:
            say(f"  {p}")
