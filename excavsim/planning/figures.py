"""Figures of one trenching plan, as the thesis draws them (Singh 1995 ch. 4, §5.3).

* :func:`plot_feasible_sets`: each constraint's set of actions as solid cubes in (k, alpha, d1)
  space, and their composites (Figs. 38-49, 85);
* :func:`plot_limits`: where the geometric constraints and where the force constraint limit the
  dig, in (alpha, d1) per entry point k (Fig. 87);
* :func:`plot_dig`: the chosen dig in the arm plane over the mapped surface and the goal, with the
  predicted force and joint torques along it.

The planner never imports this module (figures are an observer of a :class:`PlanResult`). It uses
matplotlib's object-oriented API on an Agg canvas: no pyplot, no display, no global state.
"""

from __future__ import annotations

import math
import pathlib

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from matplotlib.colors import ListedColormap, to_rgb
from matplotlib.figure import Figure
from matplotlib.patches import Patch
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from excavsim.config import TrenchGoal
from excavsim.errors import ConfigError, DataFileError, UsageError
from excavsim.handoff.goal import SurfaceProfile, goal_profile
from excavsim.handoff.maps import ElevationMap
from excavsim.planning.constraints import CONSTRAINTS
from excavsim.planning.search import PlanResult
from excavsim.robot.kinematics import PlanarArm

GEOMETRY_LIMITED, NO_DIG, FORCE_NO_DIG, FORCE_LIMITED = 0, 1, 2, 3  # the codes of PlanResult.limiting
PHASE_NAMES = ("penetrate", "drag", "curl")
PHASE_COLOURS = ("#1f77b4", "#2ca02c", "#d62728")
JOINT_NAMES = ("shoulder", "elbow", "wrist pitch")
_LIMIT_COLOURS = ("#ffffff", "#c6d3e0", "#1a1a1a", "#5a5a5a")  # Fig. 87: geometry white, force black
_LIMIT_LABELS = ("feasible, d2 set by geometry", "no geometric dig", "force: no dig within the limits",
                 "force: d2 cut short")
_CUBE_COLOURS = {"shaping": "#8c6d31", "sensible": "#6b6ecf", "volume": "#e7969c", "reachability": "#7b9ed6",
                 "force": "#bd9e39", "geometric": "#9c9ede", "feasible": "#4daf4a", "feasible_volume": "#31a354"}


def limit_classes(result: PlanResult) -> np.ndarray:
    """What limits each cell (Fig. 87), from ``result.feasible`` and ``result.limiting``.

    ``GEOMETRY_LIMITED`` (0): feasible, the geometric constraints end its drag d2 (white in Fig. 87);
    ``NO_DIG`` (1): no dig meets the geometric constraints; ``FORCE_NO_DIG`` (2): some dig meets
    them but none stays within the torque limits; ``FORCE_LIMITED`` (3): feasible, with d2 cut short
    by the force constraint (2 and 3 are black in Fig. 87). Plan with ``classify_limits=True`` to
    tell force from geometry; otherwise feasible cells count as 0 and infeasible ones as 1.

    Returns:
        (n_k, n_alpha, n_d1) int8.
    """
    _check_grid(result)
    lim = np.asarray(result.limiting)
    return np.where(result.feasible, np.where(lim == FORCE_LIMITED, FORCE_LIMITED, GEOMETRY_LIMITED),
                    np.where(lim == FORCE_NO_DIG, FORCE_NO_DIG, NO_DIG)).astype(np.int8)


def force_limited(result: PlanResult) -> np.ndarray:
    """(n_k, n_alpha, n_d1) bool: the cells where the force constraint, not geometry, limits the dig
    (black in Fig. 87: no dig within the torque limits, or a drag cut short by them)."""
    cls = limit_classes(result)
    return (cls == FORCE_NO_DIG) | (cls == FORCE_LIMITED)


def plot_feasible_sets(result: PlanResult, path: str | pathlib.Path, *, min_volume_m3: float | None = None
                       ) -> pathlib.Path:
    """Draw each constraint's set of actions as solid cubes in (k, alpha, d1) space (Figs. 38-49).

    One 3-D panel per constraint mask of ``result.masks`` (each evaluated with the shortest drag),
    then the composite geometric set (all but force), the feasible set (some drag satisfies every
    constraint) and, with ``min_volume_m3``, the feasible digs sweeping at least that much (Fig. 49).
    The chosen action, if any, is a red star in every panel.

    Args:
        result: a plan; a pruned search only evaluates the cells before the first goal-cutting
            penetration along d1, which the figure notes (plan with ``prune=False`` for full sets).
        path: the PNG to write; parent directories are created.
        min_volume_m3: add the panel of feasible digs with at least this swept volume [m^3].

    Returns:
        ``path``.

    Raises:
        ExcavsimError: ``result`` lacks a constraint mask or its arrays do not match its grid.
    """
    _check_grid(result)
    missing = [c for c in CONSTRAINTS if c not in result.masks]
    if missing:
        raise UsageError(f"plan result has no mask for constraint(s) {missing}; expected {list(CONSTRAINTS)}")
    panels = [(c, result.masks[c]) for c in CONSTRAINTS]
    panels.append(("geometric", np.logical_and.reduce([result.masks[c] for c in CONSTRAINTS if c != "force"])))
    panels.append(("feasible", result.feasible))
    if min_volume_m3 is not None:
        vol = np.nan_to_num(result.volume, nan=-np.inf)
        panels.append(("feasible_volume", result.feasible & (vol >= min_volume_m3)))
    titles = {"geometric": "geometric (all but force)", "feasible": "feasible (all, some drag)",
              "feasible_volume": f"feasible, >= {1000 * (min_volume_m3 or 0):.1f} l"}

    ek, ea, ed = _edges(result.grid_k), np.degrees(_edges(result.grid_alpha)), _edges(result.grid_d1)
    ncols = 4
    nrows = math.ceil(len(panels) / ncols)
    fig = _figure((4.2 * ncols, 4.0 * nrows + 0.6))
    n = result.feasible.size
    for i, (name, mask) in enumerate(panels):
        ax = fig.add_subplot(nrows, ncols, i + 1, projection="3d", computed_zorder=False)
        if mask.any():
            ax.add_collection3d(_cubes(mask, (ek, ea, ed), _CUBE_COLOURS[name]))
        if result.action is not None:
            k, alpha, d1, _ = result.action
            ax.scatter([k], [math.degrees(alpha)], [d1], marker="*", s=140, c="red", edgecolors="black",
                       linewidths=0.5, zorder=10, depthshade=False)
        ax.set_xlim(ek[0], ek[-1])
        ax.set_ylim(ea[0], ea[-1])
        ax.set_zlim(ed[0], ed[-1])
        ax.set_xlabel("k [m]", labelpad=2)
        ax.set_ylabel("alpha [deg]", labelpad=2)
        ax.set_zlabel("d1 [m]", labelpad=2)
        ax.tick_params(labelsize=7, pad=0)
        ax.view_init(elev=22, azim=-55)
        ax.set_title(f"{titles.get(name, name)}: {int(mask.sum())} of {n}", fontsize=10)
    fig.suptitle(_headline(result), fontsize=11)
    pruned = result.counts.get("pruned_d1", 0)
    if pruned:
        fig.text(0.5, 0.01, f"pruned search: {pruned} cells past the first goal-cutting penetration along d1 "
                 "were not evaluated and show as outside every set", ha="center", fontsize=8, color="#555555")
    # A tight bounding box would draw every 3-D panel twice.
    fig.subplots_adjust(left=0.0, right=0.97, top=0.9, bottom=0.05, wspace=0.12, hspace=0.15)
    return _save(fig, path, tight=False)


def plot_limits(result: PlanResult, path: str | pathlib.Path, *, max_panels: int = 12) -> pathlib.Path:
    """Map where the geometric constraints and where the force constraint limit the dig (Fig. 87).

    As the thesis draws it: one (alpha, d1) image per entry point k (every k of the grid up to
    ``max_panels``, otherwise evenly spaced ones and the chosen one), cells coloured as in
    :func:`limit_classes`: white where geometry ends the drag, black and dark grey where the force
    constraint does, light blue where no dig meets the geometric constraints. The chosen action is a
    red star.

    Args:
        result: a plan (with ``classify_limits=True``, or every feasible cell is white).
        path: the PNG to write; parent directories are created.
        max_panels: most k slices drawn.

    Returns:
        ``path``.
    """
    cls = limit_classes(result)
    n_k = len(result.grid_k)
    chosen_k = None
    if result.action is not None:
        chosen_k = int(np.argmin(np.abs(result.grid_k - result.action[0])))
    if n_k <= max_panels:
        slices = list(range(n_k))
    else:
        slices = sorted(set(np.linspace(0, n_k - 1, max_panels - 1).round().astype(int)) |
                        ({chosen_k} if chosen_k is not None else set()))
    ncols = min(6, len(slices))
    nrows = math.ceil(len(slices) / ncols)
    fig = _figure((2.6 * ncols + 0.5, 2.5 * nrows + 1.2))
    cmap = ListedColormap(_LIMIT_COLOURS)
    ea, ed = np.degrees(_edges(result.grid_alpha)), _edges(result.grid_d1)
    for i, ki in enumerate(slices):
        ax = fig.add_subplot(nrows, ncols, i + 1)
        ax.pcolormesh(ea, ed, cls[ki].T, cmap=cmap, vmin=-0.5, vmax=3.5, edgecolors="#dddddd", linewidth=0.1)
        if ki == chosen_k:
            ax.plot([math.degrees(result.action[1])], [result.action[2]], marker="*", ms=12, color="red",
                    mec="black", mew=0.5)
        ax.set_title(f"k = {result.grid_k[ki]:.2f} m", fontsize=9)
        ax.tick_params(labelsize=7)
        if i % ncols == 0:
            ax.set_ylabel("d1 [m]")
        if i >= len(slices) - ncols:
            ax.set_xlabel("alpha [deg]")
    counts = np.bincount(cls.ravel(), minlength=4)
    fig.legend(handles=[Patch(facecolor=c, edgecolor="#888888", label=f"{lab} ({n})") for c, lab, n in
                        zip(_LIMIT_COLOURS, _LIMIT_LABELS, counts)],
               loc="lower center", ncol=4, fontsize=8, frameon=False)
    fig.suptitle(_headline(result) + f"\nforce-limited (black, grey): {int(counts[2] + counts[3])} cells",
                 fontsize=10)
    fig.subplots_adjust(left=0.06, right=0.98, top=0.86, bottom=0.1 + 0.05 / nrows, wspace=0.25, hspace=0.45)
    return _save(fig, path, tight=False)


def plot_dig(result: PlanResult, goal: TrenchGoal, surface: SurfaceProfile | ElevationMap, path: str | pathlib.Path,
             *, torque_limits_nm: np.ndarray | None = None, arm: PlanarArm | None = None,
             width_m: float | None = None, tick_spacing: int = 1) -> pathlib.Path:
    """Draw the chosen dig in the arm plane and the predicted force and joint torques along it.

    Top: the mapped surface, the goal profile (dashed), the tip path coloured by phase and the blade
    at each sample (a tick from the cutting edge towards the heel, at the pitch). Below, against the
    distance travelled by the tip: the predicted soil force (F_x, F_z, |F|) and one panel per planar
    joint with its torque and, given ``torque_limits_nm``, the relief limits as dashed lines.

    Args:
        result: a plan with a chosen action.
        goal: the trench the plan was made for.
        surface: the mapped surface along the arm plane, or the elevation map itself (then ``arm``
            and ``width_m`` are needed to take the profile as the planner does).
        path: the PNG to write; parent directories are created.
        torque_limits_nm: (3,) relief limits of shoulder, elbow, wrist pitch [N m].
        arm: the planar arm (only with an elevation map).
        width_m: bucket width the profile is averaged across [m] (only with an elevation map).
        tick_spacing: draw the blade at every ``tick_spacing``-th sample.

    Returns:
        ``path``.

    Raises:
        ExcavsimError: the plan chose no dig, its path arrays disagree, or a map came without
            ``arm`` and ``width_m``.
    """
    if result.action is None:
        raise UsageError(f"the plan chose no dig ({result.reason}); plot_dig needs a plan with an action")
    poses, phases = np.asarray(result.poses, float), np.asarray(result.phases)
    forces, torques = np.asarray(result.forces, float), np.asarray(result.torques, float)
    s_n = poses.shape[0]
    if poses.ndim != 2 or poses.shape[1] != 3 or s_n < 2 or phases.shape != (s_n,) or forces.shape != (s_n, 2) \
            or torques.shape != (s_n, 3):
        raise UsageError(f"plan result's path arrays disagree: poses {poses.shape} (S, 3), phases {phases.shape} "
                         f"(S,), forces {forces.shape} (S, 2), torques {torques.shape} (S, 3), S >= 2")
    if isinstance(surface, ElevationMap):
        if arm is None or width_m is None:
            raise UsageError("plot_dig with an elevation map needs arm= and width_m= to take the surface "
                             "profile; or pass a SurfaceProfile")
        surface = SurfaceProfile.from_map(surface, arm, math.radians(goal.waist_deg), width_m)
    limits = None
    if torque_limits_nm is not None:
        limits = np.asarray(torque_limits_nm, float)
        if limits.shape != (3,):
            raise ConfigError(f"torque_limits_nm must be 3 values [N m] (shoulder, elbow, wrist pitch); "
                              f"given shape {limits.shape}")

    fig = _figure((9.0, 11.0))
    gs = fig.add_gridspec(5, 1, height_ratios=[3.2, 1.2, 1.0, 1.0, 1.0], hspace=0.35)
    ax = fig.add_subplot(gs[0])
    x_lo = min(goal.near_x_m, poses[:, 0].min()) - 0.3
    x_hi = max(goal.far_x_m, poses[:, 0].max()) + 0.3
    xs = np.linspace(x_lo, x_hi, 400)
    z_surf = surface(xs)
    ax.fill_between(xs, z_surf, min(z_surf.min(), goal.surface_z_m - goal.depth_m) - 0.1, color="#e8d8b0",
                    zorder=0)
    ax.plot(xs, z_surf, color="#8c6d31", lw=1.5, label="mapped surface")
    ax.plot(xs, goal_profile(goal, xs), color="black", ls="--", lw=1.2, label="goal")
    for ph, (name, colour) in enumerate(zip(PHASE_NAMES, PHASE_COLOURS)):
        # Each phase's segments start at its first sample's predecessor so the path is continuous.
        idx = np.nonzero(phases == ph)[0]
        if idx.size == 0:
            continue
        seg = np.arange(max(idx[0] - 1, 0), idx[-1] + 1)
        ax.plot(poses[seg, 0], poses[seg, 1], color=colour, lw=2.2, label=name, zorder=3)
    # The blade: from the cutting edge towards the heel, pitch below horizontal towards -x.
    tick = 0.06
    sel = np.arange(0, s_n, max(1, int(tick_spacing)))
    p = poses[sel]
    heel = p[:, :2] + tick * np.stack([np.cos(p[:, 2]), np.sin(p[:, 2])], axis=-1)
    ax.add_collection(LineCollection(np.stack([p[:, :2], heel], axis=1), colors=[PHASE_COLOURS[i] for i in
                                                                                 phases[sel]], lw=0.9, zorder=2))
    ax.plot(poses[:, 0], poses[:, 1], ".", color="black", ms=2.5, zorder=4)
    k, alpha, d1, d2 = result.action
    ax.plot([k], [float(surface(np.array([k]))[0])], marker="v", color="black", ms=7, zorder=5)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlim(x_lo, x_hi)
    ax.set_xlabel("x, radial distance from the waist axis [m]")
    ax.set_ylabel("z [m]")
    ax.legend(loc="lower center", fontsize=8, ncol=5, framealpha=0.9)
    ax.set_title(f"k {k:.2f} m, alpha {math.degrees(alpha):.1f} deg, d1 {d1:.3f} m, d2 {d2:.3f} m: "
                 f"{1000 * result.volume_m3:.1f} l swept ({result.reason})", fontsize=10)

    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(poses[:, :2], axis=0), axis=1))])
    axf = fig.add_subplot(gs[1])
    axf.plot(s, forces[:, 0], label="F_x")
    axf.plot(s, forces[:, 1], label="F_z")
    axf.plot(s, np.linalg.norm(forces, axis=1), color="black", lw=1.0, label="|F|")
    axf.set_ylabel("soil force [N]")
    axf.legend(loc="upper left", fontsize=8, ncol=3)
    _shade_phases(axf, s, phases)
    for j in range(3):
        axt = fig.add_subplot(gs[2 + j], sharex=axf)
        axt.plot(s, torques[:, j], color="C%d" % (j + 3), label=JOINT_NAMES[j])
        if limits is not None:
            for sign in (1.0, -1.0):
                axt.axhline(sign * limits[j], color="C%d" % (j + 3), ls="--", lw=1.0)
            peak = np.abs(torques[:, j]).max() / limits[j]
            axt.text(0.99, 0.92, f"peak {100 * peak:.0f} % of {limits[j]:.0f} N m", transform=axt.transAxes,
                     ha="right", va="top", fontsize=8)
        axt.set_ylabel(f"{JOINT_NAMES[j]}\n[N m]", fontsize=9)
        _shade_phases(axt, s, phases)
        if j < 2:
            axt.tick_params(labelbottom=False)
    axf.tick_params(labelbottom=False)
    axt.set_xlabel("distance along the tip path [m]")
    return _save(fig, path)


# -- helpers ------------------------------------------------------------------------------------------
def _figure(size: tuple[float, float]) -> Figure:
    fig = Figure(figsize=size, dpi=100)
    FigureCanvasAgg(fig)
    return fig


def _save(fig: Figure, path: str | pathlib.Path, *, tight: bool = True) -> pathlib.Path:
    path = pathlib.Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path, format="png", bbox_inches="tight" if tight else None)
    except OSError as exc:
        raise DataFileError(f"{path}: cannot write the figure ({exc.strerror or exc})") from None
    return path


def _cubes(mask: np.ndarray, edges: tuple[np.ndarray, np.ndarray, np.ndarray], colour: str) -> Poly3DCollection:
    """The filled cells of a 3-D ``mask`` as solid cubes: one collection of their exposed faces.

    What ``Axes3D.voxels`` draws, but as a single collection (``voxels`` makes one per cell, which
    takes about a minute on the planner's 20 x 10 x 49 grid); faces are shaded by their direction.
    """
    quads, shades = [], []
    padded = np.pad(mask, 1)
    inner = (slice(1, -1),) * 3
    for axis in range(3):
        u, v = [a for a in range(3) if a != axis]
        for side, shade in ((0, 0.65 + 0.1 * axis), (1, 1.0 - 0.1 * axis)):
            shifted = np.roll(padded, -1 if side else 1, axis=axis)[inner]
            cells = np.argwhere(mask & ~shifted)  # (F, 3) cells with this face exposed
            if cells.size == 0:
                continue
            corners = np.empty((len(cells), 4, 3))
            for c, (du, dv) in enumerate(((0, 0), (1, 0), (1, 1), (0, 1))):
                idx = cells.copy()
                idx[:, axis] += side
                idx[:, u] += du
                idx[:, v] += dv
                for a in range(3):
                    corners[:, c, a] = edges[a][idx[:, a]]
            quads.append(corners)
            shades.append(np.full(len(cells), shade))
    rgb = np.asarray(to_rgb(colour))
    colours = np.clip(np.concatenate(shades)[:, None] * rgb[None, :], 0.0, 1.0)
    return Poly3DCollection(np.concatenate(quads), facecolors=colours, edgecolors=(0.0, 0.0, 0.0, 0.15),
                            linewidths=0.2)


def _edges(centres: np.ndarray) -> np.ndarray:
    """Cell edges around increasing grid centres (n,) -> (n + 1,)."""
    c = np.asarray(centres, float)
    if c.size == 1:
        h = 0.5 * (abs(c[0]) or 1.0) * 0.1
        return np.array([c[0] - h, c[0] + h])
    mid = 0.5 * (c[1:] + c[:-1])
    return np.concatenate([[c[0] - (mid[0] - c[0])], mid, [c[-1] + (c[-1] - mid[-1])]])


def _check_grid(result: PlanResult) -> None:
    shape = (len(result.grid_k), len(result.grid_alpha), len(result.grid_d1))
    arrays = {"feasible": result.feasible, "limiting": result.limiting, "volume": result.volume,
              **{f"masks[{c!r}]": m for c, m in result.masks.items()}}
    bad = {name: np.shape(a) for name, a in arrays.items() if np.shape(a) != shape}
    if bad:
        raise UsageError(f"plan result arrays do not match its grid (n_k, n_alpha, n_d1) = {shape}: {bad}")


def _headline(result: PlanResult) -> str:
    if result.action is None:
        chosen = f"no dig: {result.reason}"
    else:
        k, alpha, d1, d2 = result.action
        chosen = f"chosen k {k:.2f} m, alpha {math.degrees(alpha):.0f} deg, d1 {d1:.2f} m, d2 {d2:.3f} m"
    return f"{int(result.feasible.sum())} feasible of {result.feasible.size} cells; {chosen}"


def _shade_phases(ax, s: np.ndarray, phases: np.ndarray) -> None:
    """Shade the spans of distance ``s`` spent in each phase."""
    for ph, colour in enumerate(PHASE_COLOURS):
        idx = np.nonzero(phases == ph)[0]
        if idx.size:
            ax.axvspan(s[max(idx[0] - 1, 0)], s[idx[-1]], color=colour, alpha=0.07, lw=0)
    ax.axhline(0.0, color="#999999", lw=0.5)
    ax.tick_params(labelsize=8)
