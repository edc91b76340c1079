"""The thesis' planner figures (Singh 1995 §3.4.2.3, §5.3, ch. 6), drawn by ``excavsim figures``.

Figs. 22 (rotation centres, :mod:`excavsim.planning.rotation`), 82-84 (tip and gravity torques along
two similar paths, eqs. 28-31), 85-88 (the force constraint in the action space and the torque
objectives; 87 is ``excavsim plan``'s limits figure) and 91 (planning time per dig over an episode).
They plan on the flat 0.5 m fill of the soil box, as ``excavsim plan`` does by default, with the
straight trench of ``configs/trenches``; Figs. 82-84 measure the tip forces by driving the planned
path through the world's soil model (:mod:`excavsim.studies.figures.drags`). Figure code reused from
:mod:`excavsim.planning.figures`.
"""

from __future__ import annotations

import math
import pathlib

import mujoco
import numpy as np

from excavsim import constants
from excavsim.config import PlannerConfig, load_planner_config, load_robot_config, load_trench_goal
from excavsim.handoff.episode import EpisodeObserver
from excavsim.handoff.goal import SurfaceProfile, goal_profile
from excavsim.handoff.maps import ElevationMap
from excavsim.studies.figures import drags
from excavsim.planning import figures as plan_figures
from excavsim.planning.figures import _cubes, _edges, _figure, _save
from excavsim.planning.objectives import cumulative_torque
from excavsim.planning.predictor import WedgePredictor
from excavsim.planning.rotation import closest_admissible_radius, drag_rotation_radius, minimum_drag_rake
from excavsim.planning.search import PlanResult, TrenchPlanner
from excavsim.robot.extract import arm_from_model
from excavsim.robot.reachability import load_or_build
from excavsim.robot.statics import gravity_torques, tip_wrench_torques

JOINTS = ("shoulder", "elbow", "wrist pitch")
SHIFT_M = 0.10  # Fig. 82: path B is path A moved this far towards the robot [m]
FORCE_FIGURE_WRIST_NM = 500.0  # Figs. 85-87: the weaker wrist of §7.2.2 / Fig. 91(a), so that force limits show


def _model() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(constants.SCENE_XML))


def _flat_map() -> ElevationMap:
    """The soil box of models/soil_box (3 m square from x = 0.55 m), flat at the 0.5 m fill (as `plan`)."""
    return ElevationMap(0.55, -1.5, 0.05, np.full((60, 60), 0.5), np.ones((60, 60), bool), 0.0)


def _planner(ctx, *, wrist_nm: float | None = None, config: PlannerConfig | None = None,
             unlimited: bool = False) -> TrenchPlanner:
    """A planner as `excavsim plan` builds it (cached on ``ctx`` per arguments)."""
    key = ("planner", wrist_nm, None if config is None else config.model_dump_json(), unlimited)
    cache = ctx.cache
    if key not in cache:
        model = _model()
        arm = arm_from_model(model)
        width = float(model.numeric(constants.BUCKET_WIDTH_NUMERIC).data[0])
        capacity = float(model.numeric(constants.BUCKET_CAPACITY_NUMERIC).data[0])
        j = load_robot_config().joints
        limits = np.array([j.shoulder.torque_limit_nm, j.elbow.torque_limit_nm,
                           j.wrist_pitch.torque_limit_nm if wrist_nm is None else wrist_nm])
        if unlimited:  # the geometric constraints alone: torque limits no dig can reach
            limits = np.full(3, 1e12)
        cfg = config or load_planner_config()
        goal = load_trench_goal(constants.TRENCHES_DIR / "straight.yaml")
        cache[key] = TrenchPlanner(arm, load_or_build(arm), limits, width, capacity, goal, cfg,
                                   WedgePredictor(ctx.soil, width, capacity_m3=cfg.heaped_capacity_factor * capacity),
                                   ctx.soil.density_kg_m3)
    return cache[key]


def _plan(ctx, key: str, planner: TrenchPlanner, **kwargs) -> PlanResult:
    cache = ctx.cache
    if key not in cache:
        cache[key] = planner.plan(_flat_map(), **kwargs)
    return cache[key]


def _force_plans(ctx) -> tuple[TrenchPlanner, PlanResult, PlanResult]:
    """Figs. 85-87's plans without the volume constraint (§7.2.2): the 500 N m wrist, and geometry alone."""
    cfg = load_planner_config().model_copy(update={"volume_constraint": False})
    force = _planner(ctx, wrist_nm=FORCE_FIGURE_WRIST_NM, config=cfg)
    geometric = _planner(ctx, config=cfg, unlimited=True)
    return (force, _plan(ctx, "force", force, prune=False, classify_limits=True),
            _plan(ctx, "geometric", geometric, prune=False, classify_limits=True))


# -- Fig. 22 --------------------------------------------------------------------------------------------
def fig22(ctx, path: pathlib.Path) -> str:
    """Fig. 22: distance to the drag's rotation centre for several rates, and the closest admissible one."""
    model = _model()
    p0 = model.site(f"{constants.BUCKET_PROFILE_SITE_PREFIX}0").pos
    p1 = model.site(f"{constants.BUCKET_PROFILE_SITE_PREFIX}1").pos
    length = float(np.linalg.norm(p1 - p0))  # the flat bottom (blade) from the cutting edge
    cfg = load_planner_config()
    pitch = np.radians(np.linspace(2, 60, 300))
    fig = _figure((7.0, 4.2))
    ax = fig.add_subplot()
    ax.plot(np.degrees(pitch), closest_admissible_radius(length, pitch), "k--", label="closest admissible centre")
    zetas = []
    for i, w in enumerate((25, 50, 75, 100)):
        omega = math.radians(w)
        ax.axhline(float(drag_rotation_radius(omega)), color=f"C{i}", label=f"omega {w} deg/m")
        z = float(minimum_drag_rake(length, omega))
        zetas.append((w, math.degrees(z)))
        ax.plot([math.degrees(z)], [float(drag_rotation_radius(omega))], "o", color=f"C{i}")
    ax.axvline(cfg.zeta_deg, color="#888888", lw=0.8, ls=":", label=f"configured zeta {cfg.zeta_deg:g} deg")
    ax.set_ylim(0, 4)
    ax.set_xlabel("pitch (rake) angle [deg]")
    ax.set_ylabel("distance from the tip to the rotation centre [m]")
    ax.set_title(f"Fig. 22: rotation centres while dragging; bottom {100 * length:.0f} cm long; "
                 f"zeta(50) = {dict(zetas)[50]:.1f} deg", fontsize=9)
    ax.legend(fontsize=7)
    _save(fig, path)
    return (f"bottom {length:.2f} m: zeta(omega) = " + ", ".join(f"{w} deg/m -> {z:.1f} deg" for w, z in zetas)
            + f"; thesis zeta(50) ~ 8 deg, configured {cfg.zeta_deg:g} deg")


# -- Figs. 82-84 ----------------------------------------------------------------------------------------
def _paths(ctx) -> dict:
    cache = ctx.cache
    if "paths" in cache:
        return cache["paths"]
    planner = _planner(ctx)
    res = _plan(ctx, "default", planner)
    a = np.asarray(res.poses, float)
    b = a + np.array([-SHIFT_M, 0.0, 0.0])  # B: the same dig entered 10 cm nearer the robot
    drive = drags.KinematicDrive(ctx.world())
    above = a[0] + [0.0, 0.1, 0.0]
    drive.place(above)
    drive.line(above, a[0], 0.1)
    start = drive.rows
    drive.follow(a, 0.15)  # configs/executor.yaml's path speed
    rec = drive.record(from_row=start)
    s_a = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(a[:, :2], axis=0), axis=1))])
    force = np.stack([np.interp(s_a, rec.s_m, rec.force_plane_n[:, k]) for k in range(2)], axis=-1)
    arm = planner.arm
    q_a, ok_a = arm.inverse(a)
    q_b, ok_b = arm.inverse(b)
    wrench = np.concatenate([force, np.zeros((len(a), 1))], axis=1)
    cache["paths"] = dict(a=a, b=b, s=s_a, force=force, ok=bool(ok_a.all() and ok_b.all()), res=res,
                          tip_a=-tip_wrench_torques(arm, q_a, wrench), tip_b=-tip_wrench_torques(arm, q_b, wrench),
                          grav_a=gravity_torques(arm, q_a), grav_b=gravity_torques(arm, q_b))
    return cache["paths"]


def fig82(ctx, path: pathlib.Path) -> str:
    """Fig. 82: two similar tip paths, A (a planned dig) and B (A entered 10 cm further out)."""
    p = _paths(ctx)
    fig = _figure((8.0, 3.8))
    ax = fig.add_subplot()
    xs = np.linspace(1.4, 3.4, 200)
    goal = load_trench_goal(constants.TRENCHES_DIR / "straight.yaml")
    ax.fill_between(xs, 0.5, 0.1, color="#e8d8b0")
    ax.plot(xs, goal_profile(goal, xs), "k--", lw=1.0, label="goal")
    ax.plot(p["a"][:, 0], p["a"][:, 1], "-", color="C0", lw=2, label="A (planned)")
    ax.plot(p["b"][:, 0], p["b"][:, 1], "o", color="C1", ms=3, label="B (A - 10 cm in x)")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("z [m]")
    k, alpha, d1, d2 = p["res"].action
    ax.set_title(f"Fig. 82: tip paths; A is the plan k {k:.2f} m, alpha {math.degrees(alpha):.0f} deg, d1 {d1:.2f} m, "
                 f"d2 {d2:.3f} m", fontsize=9)
    ax.legend(fontsize=7)
    _save(fig, path)
    return (f"A: k {k:.2f} m, alpha {math.degrees(alpha):.0f} deg, d1 {d1:.2f} m, d2 {d2:.3f} m; "
            f"B = A - {SHIFT_M:.2f} m in x; both reachable: {p['ok']}")


def _torque_figure(ctx, path: pathlib.Path, key: str, title: str) -> str:
    p = _paths(ctx)
    ta, tb = p[f"{key}_a"], p[f"{key}_b"]
    fig = _figure((8.0, 6.0))
    axes = fig.subplots(3, 1, sharex=True)
    diffs = []
    for j, ax in enumerate(axes):
        ax.plot(p["s"], ta[:, j], "-", color=f"C{j}", label="A")
        ax.plot(p["s"], tb[:, j], "o", color=f"C{j}", ms=3, mfc="none", label="B")
        ax.set_ylabel(f"{JOINTS[j]} [N m]", fontsize=8)
        ax.legend(fontsize=7, loc="upper left")
        diffs.append((float(np.abs(ta[:, j]).max()), float(np.abs(ta[:, j] - tb[:, j]).max())))
    axes[-1].set_xlabel("distance along the path [m]")
    fig.suptitle(title, fontsize=9)
    _save(fig, path)
    return "; ".join(f"{n}: peak {pk:.0f} N m, A-B up to {d:.0f} N m ({100 * d / max(pk, 1e-9):.0f} %)"
                     for n, (pk, d) in zip(JOINTS, diffs))


def fig83(ctx, path: pathlib.Path) -> str:
    """Fig. 83: torques due to tip forces (eq. 29) measured along A, applied on A and on B."""
    return _torque_figure(ctx, path, "tip", "Fig. 83: torques due to the tip forces measured along A (world), "
                                            "on A (lines) and B (circles)")


def fig84(ctx, path: pathlib.Path) -> str:
    """Fig. 84: torques due to gravity (eq. 31) along A and B."""
    return _torque_figure(ctx, path, "grav", "Fig. 84: torques due to gravity on the links, A (lines) and B (circles)")


# -- Figs. 85-88 ----------------------------------------------------------------------------------------
def fig85(ctx, path: pathlib.Path) -> str:
    """Fig. 85: the force constraint's set in (k, alpha, d1), beside the reachability constraint's."""
    _, res, _ = _force_plans(ctx)
    edges = (_edges(res.grid_k), np.degrees(_edges(res.grid_alpha)), _edges(res.grid_d1))
    fig = _figure((10.0, 4.6))
    counts = {}
    for i, name in enumerate(("reachability", "force")):
        ax = fig.add_subplot(1, 2, i + 1, projection="3d", computed_zorder=False)
        mask = res.masks[name]
        counts[name] = int(mask.sum())
        if mask.any():
            ax.add_collection3d(_cubes(mask, edges, plan_figures._CUBE_COLOURS[name]))
        for a, lim in zip(("x", "y", "z"), edges):
            getattr(ax, f"set_{a}lim")(lim[0], lim[-1])
        ax.set_xlabel("k [m]")
        ax.set_ylabel("alpha [deg]")
        ax.set_zlabel("d1 [m]")
        ax.view_init(elev=22, azim=-55)
        ax.set_title(f"{name}: {counts[name]} of {mask.size} cells", fontsize=9)
    both = int((res.masks["force"] & res.masks["reachability"]).sum())
    fig.suptitle(f"Fig. 85: force constraint (wrist {FORCE_FIGURE_WRIST_NM:.0f} N m, no volume constraint) beside "
                 "reachability", fontsize=9)
    _save(fig, path, tight=False)
    return (f"force-feasible {counts['force']}, reachable {counts['reachability']} of {res.feasible.size} cells; "
            f"{both} are both ({100 * both / max(counts['force'], 1):.0f} % of the force set lies in reachability's)")


def fig86(ctx, path: pathlib.Path) -> str:
    """Fig. 86: at one k, the (alpha, d1, d2) digs meeting the geometric constraints and those also
    meeting the force constraint (the longest admissible d2 of each cell, drawn as a column)."""
    planner, force, geom = _force_plans(ctx)
    limited = plan_figures.force_limited(force).sum(axis=(1, 2))
    ki = int(np.argmax(limited))
    step = planner.cfg.sample_spacing_m
    d2_bins = np.arange(0.0, planner.cfg.d2_max_m + step / 2, 4 * step)
    sets = {}
    for name, res in (("geometric", geom), ("force", force)):
        d2 = np.where(res.feasible[ki], np.nan_to_num(res.d2[ki], nan=-1.0), -1.0)
        sets[name] = d2[:, :, None] >= d2_bins[None, None, :]
    top = max(float(np.nanmax(np.where(geom.feasible[ki], geom.d2[ki], np.nan))), 4 * step)
    edges = (np.degrees(_edges(force.grid_alpha)), _edges(force.grid_d1),
             np.concatenate([d2_bins - 2 * step, [d2_bins[-1] + 2 * step]]))
    fig = _figure((10.0, 4.6))
    for i, (name, mask) in enumerate(sets.items()):
        ax = fig.add_subplot(1, 2, i + 1, projection="3d", computed_zorder=False)
        if mask.any():
            ax.add_collection3d(_cubes(mask, edges, plan_figures._CUBE_COLOURS["geometric" if i == 0 else "force"]))
        ax.set_xlim(edges[0][0], edges[0][-1])
        ax.set_ylim(edges[1][0], edges[1][-1])
        ax.set_zlim(0, top)
        ax.set_xlabel("alpha [deg]")
        ax.set_ylabel("d1 [m]")
        ax.set_zlabel("d2 [m]")
        ax.view_init(elev=22, azim=-60)
        ax.set_title(f"{name}: {int(mask.sum())} (alpha, d1, d2) cells", fontsize=9)
    fig.suptitle(f"Fig. 86: k = {force.grid_k[ki]:.2f} m (the k with the most force-limited cells), wrist "
                 f"{FORCE_FIGURE_WRIST_NM:.0f} N m, no volume constraint", fontsize=9)
    _save(fig, path, tight=False)
    g, f = geom.feasible[ki], force.feasible[ki]
    shorter = int(np.sum(f & g & (force.d2[ki] < geom.d2[ki] - 1e-9)))
    return (f"k {force.grid_k[ki]:.2f} m: {int(g.sum())} (alpha, d1) cells geometric, {int(f.sum())} also "
            f"force-feasible; force shortens d2 in {shorter}, removes {int((g & ~f).sum())}")


def fig87(ctx, path: pathlib.Path) -> str:
    """Fig. 87: where the geometric and where the force constraints limit the dig (`excavsim plan`'s figure)."""
    _, res, _ = _force_plans(ctx)
    plan_figures.plot_limits(res, path)
    cls = np.bincount(plan_figures.limit_classes(res).ravel(), minlength=4)
    return (f"wrist {FORCE_FIGURE_WRIST_NM:.0f} N m: {cls[0]} cells limited by geometry, {cls[2] + cls[3]} by force "
            f"({cls[3]} with d2 cut short, {cls[2]} with no dig), {cls[1]} with no geometric dig")


def fig88(ctx, path: pathlib.Path) -> str:
    """Fig. 88: the digs chosen by least peak torque and by least cumulative torque (eq. 44, same volume bound)."""
    base = load_planner_config()
    rows = []
    fig = _figure((8.0, 6.5))
    ax, axt = fig.subplots(2, 1, gridspec_kw={"height_ratios": [2, 1]})
    surface = SurfaceProfile.from_map(_flat_map(), _planner(ctx).arm, 0.0, _planner(ctx).width)
    xs = np.linspace(1.5, 3.4, 300)
    ax.fill_between(xs, surface(xs), 0.1, color="#e8d8b0")
    goal = load_trench_goal(constants.TRENCHES_DIR / "straight.yaml")
    ax.plot(xs, goal_profile(goal, xs), "k--", lw=1.0, label="goal")
    for i, aux in enumerate(("peak_torque", "cumulative_torque")):
        cfg = base.model_copy(update={"objective": "lexicographic", "auxiliary": aux})
        planner = _planner(ctx, config=cfg)
        res = _plan(ctx, f"fig88-{aux}", planner)
        poses, torques = np.asarray(res.poses), np.asarray(res.torques)
        peak = float((np.abs(torques) / planner.limits).max())
        cum = float(cumulative_torque(torques, poses))
        k, alpha, d1, d2 = res.action
        label = f"({'ab'[i]}) least {aux.replace('_', ' ')}"
        ax.plot(poses[:, 0], poses[:, 1], "-o"[0], color=f"C{i}", lw=2, label=label)
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(poses[:, :2], axis=0), axis=1))])
        axt.plot(s, np.abs(torques).sum(axis=1), color=f"C{i}", label=label)
        rows.append(f"{label}: k {k:.2f} m alpha {math.degrees(alpha):.0f} deg d1 {d1:.2f} m d2 {d2:.3f} m, "
                    f"{1000 * res.volume_m3:.1f} l, peak {100 * peak:.0f} % of a limit, cumulative {cum:.0f} N m m")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("z [m]")
    ax.legend(fontsize=7)
    axt.set_xlabel("distance along the path [m]")
    axt.set_ylabel("sum |tau| [N m]")
    fig.suptitle(f"Fig. 88: digs of > {100 * base.volume_threshold:.0f} % of capacity chosen by two criteria",
                 fontsize=9)
    _save(fig, path)
    return "; ".join(rows)


# -- Fig. 91 --------------------------------------------------------------------------------------------
WEAK_WRIST = {"joints": {"wrist_pitch": {"torque_limit_nm": 500}}}
FIG91_RUNS = (("(a) wrist 500 N m, max volume + least peak torque", WEAK_WRIST, {}),
              ("(b) wrist 1000 N m, max volume only", {}, {"objective": "volume"}),
              ("(c) wrist 1000 N m, max volume + least peak torque", {}, {}))


class _PlanWork(EpisodeObserver):
    """Counts what each cycle's plan evaluated: machine-independent work beside the wall-clock time."""

    def __init__(self):
        self.rows: list[tuple[int, int, int]] = []

    def planned(self, index, plan, dig):
        if plan is not None:
            self.rows.append((index, int(plan.counts.get("evaluated", 0)), int(plan.counts.get("force_samples", 0))))


def fig91(ctx, path: pathlib.Path) -> str:
    """Fig. 91: planning time per dig over three episodes from the same start (the sand trench), and
    the work behind it (cells evaluated after pruning along d1, samples the force constraint checked)."""
    from excavsim.loop.scenario import EpisodeSpec, run_spec

    fig = _figure((8.0, 6.4))
    ax, axw = fig.subplots(2, 1, sharex=True)
    rows = []
    for i, (label, robot, planner) in enumerate(FIG91_RUNS):
        work = _PlanWork()
        res = run_spec(EpisodeSpec(name=label, seed=ctx.seed, robot=robot, planner=planner), observer=work)
        t = np.array([d.planning_s for d in res.digs])
        ax.plot(np.arange(1, len(t) + 1), t, "o-", color=f"C{i}", label=label)
        w = np.array(work.rows, float).reshape(-1, 3)
        axw.plot(w[:, 0] + 1, w[:, 2], "o-", color=f"C{i}", label=label)
        rows.append(f"{label[:3]} {len(t)} digs, {t.mean():.2f} s mean, {t.max():.2f} s max, force samples "
                    f"{int(w[0, 2]) if len(w) else 0} -> {int(w[-1, 2]) if len(w) else 0} first -> last plan "
                    f"({res.end})")
    ax.set_ylabel("planning time [s]\n(wall clock, this machine)")
    ax.set_ylim(bottom=0)
    ax.legend(fontsize=7)
    axw.set_ylabel("force-constraint samples\nevaluated")
    axw.set_xlabel("dig")
    axw.set_ylim(bottom=0)
    ax.set_title("Fig. 91: planning per dig; shaping, sensible, reachability, volume and force constraints",
                 fontsize=9)
    _save(fig, path)
    return "; ".join(rows) + " (thesis, Sparc 10: about 60 s to build the feasible set + 10 s to select)"
