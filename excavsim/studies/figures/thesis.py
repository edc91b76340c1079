"""The thesis' figures by command: ``excavsim figures [NAME ...] [--out DIR] [--list]``.

Each figure of Singh 1995 listed by :func:`figures` is redrawn from this project's
world and mind, beside the static wedge model (eq. 8, :mod:`excavsim.mechanics.wedge`) where the
thesis compares with it. The force figures (20, 54, 59, 61, 63) drive the bucket through the
world's soil model as it is (:mod:`excavsim.studies.figures.drags`): they show that model's behaviour (the
dynamic earthmoving equation's inertial term, the wedge's failure cycle, the heterogeneity of
``configs/scene.yaml``'s ``truth``), not the testbed's. The planner figures live in
:mod:`excavsim.studies.figures.plan`.

Every figure returns a one-line summary of the numbers it shows, which the command prints.
Forces from the kinematic drives are bit-reproducible for a seed on one machine; the planning
times of Fig. 91 are wall-clock and vary from run to run.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import pathlib
from collections.abc import Callable, Sequence

import numpy as np

from excavsim.config import SoilParams, get_soil, load_planner_config, load_scene_config
from excavsim.errors import ConfigError
from excavsim.studies.figures import drags
from excavsim.mechanics.wedge import critical_beta, wedge_factors, wedge_force
from excavsim.mechanics.wedge_inertia import inertial_force
from excavsim.planning.figures import _figure, _save
from excavsim.planning.predictor import WedgePredictor
from excavsim.world.simulation import Simulation

RAD = math.radians
EQ8 = "static eq. 8, no surcharge"
ENTRY_M = 0.08  # the first 8 cm of a drag: the first failures of the wedge as it is first loaded
PLANNER = "planner's model: eq. 8 + 30 % of the swept soil as surcharge"


@dataclasses.dataclass(frozen=True)
class Figure:
    """One figure of the thesis: its name, what it shows and the function that draws it."""

    name: str
    title: str
    draw: Callable[[FigureContext, pathlib.Path], str]


class FigureContext:
    """What several figures share, built once per command: the soil, the planners and their plans.

    Args:
        seed: the first world seed of the force experiments (Fig. 59 uses it and the next two).
    """

    def __init__(self, seed: int = 0):
        self.seed = seed
        self.soil: SoilParams = get_soil(load_scene_config().soil)
        self.cache: dict = {}  # planners, plans and measured paths shared by figures (excavsim.studies.figures.plan)

    @functools.cached_property
    def _bucket(self):
        return Simulation(seed=self.seed).soil.bucket  # the model's bucket, as the world samples it

    @property
    def width(self) -> float:
        """The bucket's width [m]."""
        return self._bucket.width

    def predictor(self) -> WedgePredictor:
        """The planner's nominal predictor, as `excavsim plan` and the loop build it."""
        cap = load_planner_config().heaped_capacity_factor * self._bucket.capacity
        return WedgePredictor(self.soil, self.width, capacity_m3=cap)

    def world(self, seed: int | None = None) -> Simulation:
        """A fresh world with the default scene (truth terms as configured)."""
        return Simulation(seed=self.seed if seed is None else seed)


def _static(ctx: FigureContext, rec: drags.DragRecord) -> tuple[np.ndarray, np.ndarray]:
    """(eq. 8 without surcharge, the planner's prediction with the swept volume) along a record [N]."""
    bare = wedge_force(rec.depth_m, rec.rake_rad, ctx.soil, ctx.width)
    planner = np.linalg.norm(ctx.predictor().predict(rec.depth_m, rec.rake_rad, rec.cut_m3), axis=-1)
    return bare, planner


def _drops(force: np.ndarray, s: np.ndarray, rel: float = 0.05) -> np.ndarray:
    """Distances [m] of the peaks after which ``force`` falls by more than ``rel`` of the peak."""
    peaks = []
    i, n = 1, len(force)
    while i < n - 1:
        if force[i] >= force[i - 1] and force[i] > force[i + 1]:
            j = i + 1
            while j < n - 1 and force[j + 1] <= force[j]:
                j += 1
            if force[i] - force[j] > rel * force[i]:
                peaks.append(s[i])
            i = j
        i += 1
    return np.asarray(peaks)


# -- force figures (the world's soil model) -------------------------------------------------------------
def fig54(ctx: FigureContext, path: pathlib.Path) -> str:
    """Fig. 54: the force trace of one horizontal drag at constant depth and speed."""
    depth, rake = 0.10, RAD(30)
    rec = drags.horizontal_drag(ctx.world(), x0_m=2.4, length_m=0.6, depth_m=depth, rake_rad=rake, speed_m_s=0.1)
    # the thesis sampled at 50 Hz and smoothed with a 9-point moving average; the world steps at 100 Hz
    sub = rec.where(np.arange(len(rec.s_m)) % 2 == 0)
    smooth = drags.moving_average(sub.magnitude_n, 9)
    bare, planner = _static(ctx, sub)
    steady = sub.s_m > ENTRY_M
    peaks = _drops(smooth[steady], sub.s_m[steady])
    spacing = float(np.median(np.diff(peaks))) if len(peaks) > 1 else float("nan")
    expect = depth / math.tan(float(critical_beta(rake, ctx.soil.phi, ctx.soil.delta)))
    crest = float(np.mean([smooth[steady][sub.s_m[steady] == p][0] for p in peaks])) if len(peaks) else float("nan")
    fig = _figure((8.0, 4.2))
    ax = fig.add_subplot()
    ax.plot(sub.s_m, sub.magnitude_n, color="#bbbbbb", lw=0.8, label="world, 50 Hz")
    ax.plot(sub.s_m, smooth, color="C0", lw=1.6, label="world, 9-point moving average")
    ax.plot(sub.s_m, bare, "k--", lw=1.2, label=EQ8)
    ax.plot(sub.s_m, planner, "k-", lw=1.0, label=PLANNER)
    for p in peaks:
        ax.axvline(p, color="C3", lw=0.5, alpha=0.5)
    top = 2.0 * float(sub.magnitude_n[steady].max())
    ax.set_ylim(0, top)
    if sub.magnitude_n.max() > top:
        ax.annotate(f"entry: {sub.magnitude_n.max():.0f} N", (float(sub.s_m[np.argmax(sub.magnitude_n)]), 0.97 * top),
                    fontsize=7, va="top")
    ax.set_xlabel("distance dragged [m]")
    ax.set_ylabel("|F| [N]")
    ax.set_title(f"Fig. 54: drag at {100 * depth:.0f} cm, rake 30 deg, 0.1 m/s; drops (red) every {spacing:.3f} m "
                 f"(d cot beta* = {expect:.3f} m)", fontsize=9)
    ax.legend(fontsize=7, loc="upper right")
    _save(fig, path)
    mean = float(sub.magnitude_n[steady].mean())
    return (f"mean {mean:.0f} N past 8 cm vs eq. 8 {float(bare[steady].mean()):.0f} N, planner "
            f"{float(planner[steady].mean()):.0f} N; largest sample {float(sub.magnitude_n.max()):.0f} N; "
            f"{len(peaks)} drops > 5 %, crests {crest:.0f} N, median spacing {spacing:.3f} m (spacings "
            f"{', '.join(f'{x:.3f}' for x in np.diff(peaks))}) vs d cot beta* {expect:.3f} m")


def fig59(ctx: FigureContext, path: pathlib.Path) -> str:
    """Fig. 59: force against distance at three depths, three runs each, beside the wedge model."""
    depths, rake = (0.05, 0.10, 0.15), RAD(30)
    fig = _figure((8.0, 4.6))
    ax = fig.add_subplot()
    means, statics = [], []
    for i, d in enumerate(depths):
        runs = []
        for run in range(3):
            rec = drags.horizontal_drag(ctx.world(ctx.seed + run), x0_m=2.4, length_m=0.3, depth_m=d, rake_rad=rake)
            sel = np.arange(len(rec.s_m)) % 8 == 0
            ax.plot(rec.s_m[sel], rec.magnitude_n[sel], "os^"[run], ms=3, color=f"C{i}", ls="none",
                    label=f"world, {100 * d:.0f} cm" if run == 0 else None)
            runs.append(rec.magnitude_n[rec.s_m > ENTRY_M].mean())
        bare, planner = _static(ctx, rec)
        ax.plot(rec.s_m, planner, color=f"C{i}", lw=1.4)
        ax.plot(rec.s_m, bare, color=f"C{i}", lw=1.0, ls="--")
        means.append(float(np.mean(runs)))
        statics.append(float(bare[rec.s_m > ENTRY_M].mean()))
    slope = float(np.polyfit(np.log(depths), np.log(means), 1)[0])
    ax.set_ylim(0, 2.2 * max(means))
    ax.set_xlabel("distance dragged [m]")
    ax.set_ylabel("|F| [N]")
    ax.set_title("Fig. 59: horizontal drags at 5, 10, 15 cm (rake 30 deg), 3 runs each (symbols); solid: planner's "
                 "model, dashed: eq. 8", fontsize=8)
    ax.legend(fontsize=7, loc="upper left")
    _save(fig, path)
    pairs = ", ".join(f"{100 * d:.0f} cm {m:.0f} N (eq. 8 {s:.0f})" for d, m, s in zip(depths, means, statics))
    return f"mean past 8 cm: {pairs}; depth exponent {slope:.2f} (eq. 8: 2)"


def fig61(ctx: FigureContext, path: pathlib.Path) -> str:
    """Fig. 61: force along a 10 deg approach for rakes of 20, 30, 40, 50 deg, in the world as configured
    and with its truth terms (speed, saw-tooth, heterogeneity) off, beside eq. 8."""
    rakes = (20, 30, 40, 50)
    quiet = drags.scene_with_truth(cohesion_rate_per_decade=0.0, brittleness_index=0.0, heterogeneity_std=0.0)
    fig = _figure((10.0, 4.4))
    axes = fig.subplots(1, 2, sharey=True)
    at5: dict[str, list] = {"world": [], "quiet": []}
    for ax, (key, scene) in zip(axes, (("world", None), ("quiet", quiet))):
        for i, r in enumerate(rakes):
            rec = drags.inclined_penetration(Simulation(scene=scene, seed=ctx.seed), x0_m=2.25, length_m=0.4,
                                             alpha_rad=RAD(10), rake_rad=RAD(r))
            bare, _ = _static(ctx, rec)
            ax.plot(rec.s_m, rec.magnitude_n, color=f"C{i}", lw=1.0, label=f"rake {r} deg")
            ax.plot(rec.s_m, bare, color=f"C{i}", lw=1.0, ls="--")
            sel = (rec.depth_m > 0.045) & (rec.depth_m < 0.055)
            at5[key].append((float(rec.magnitude_n[sel].mean()), float(bare[sel].mean()),
                             float(rec.speed_m_s[sel].mean())))
        ax.set_xlabel("distance along the 10 deg approach [m]")
        ax.set_title("world as configured" if key == "world" else "world, truth terms off", fontsize=9)
        ax.legend(fontsize=7)
    axes[0].set_ylabel("|F| [N]")
    fig.suptitle("Fig. 61: approach at alpha 10 deg, rake 20-50 deg; dashed: eq. 8 at the edge's depth", fontsize=9)
    _save(fig, path)
    world = ", ".join(f"{r} deg {w:.0f} N" for r, (w, _, _) in zip(rakes, at5["world"]))
    calm = ", ".join(f"{w:.0f}" for w, _, _ in at5["quiet"])
    eq8 = ", ".join(f"{s:.0f}" for _, s, _ in at5["world"])
    speed = ", ".join(f"{v:.3f}" for _, _, v in at5["world"])
    return (f"|F| at 5 cm depth: world {world}; truth terms off {calm} N; eq. 8 {eq8} N; the edge's speed "
            f"into the soil {speed} m/s (tool 0.1 m/s)")


def fig62(ctx: FigureContext, path: pathlib.Path) -> str:
    """Fig. 62: the failure-plane angle beta* against the rake (the wedge model alone)."""
    rake = np.radians(np.linspace(5, 110, 211))
    f = wedge_factors(rake, ctx.soil)
    fig = _figure((7.0, 4.0))
    ax = fig.add_subplot()
    ax.plot(np.degrees(rake), np.degrees(f.beta), color="C0", label="beta* [deg]")
    ax.set_xlabel("rake angle rho [deg]")
    ax.set_ylabel("failure-plane angle beta* [deg]", color="C0")
    ax2 = ax.twinx()
    ax2.plot(np.degrees(rake), f.n_gamma, color="C3", ls="--", label="N_gamma")
    ax2.set_ylabel("N_gamma (eq. 9)", color="C3")
    ax2.set_ylim(0, 6)
    i_b, i_n = int(np.argmax(f.beta)), int(np.argmin(f.n_gamma))
    ax.set_title(f"Fig. 62: phi = delta = {ctx.soil.friction_angle_deg:g} deg; beta* peaks at rho "
                 f"{np.degrees(rake[i_b]):.1f} deg, N_gamma least at {np.degrees(rake[i_n]):.1f} deg", fontsize=9)
    _save(fig, path)
    return (f"beta* rises from {np.degrees(f.beta[0]):.1f} deg (rho 5) to {np.degrees(f.beta[i_b]):.1f} deg at rho "
            f"{np.degrees(rake[i_b]):.1f}, then falls to {np.degrees(f.beta[-1]):.1f} deg (rho 110); N_gamma least "
            f"({f.n_gamma[i_n]:.3f}) at rho {np.degrees(rake[i_n]):.1f} deg")


def fig63(ctx: FigureContext, path: pathlib.Path) -> str:
    """Fig. 63: force against speed (alpha 10 deg, rho 30 deg) beside the static model."""
    speeds = np.array([0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 1.5])
    world, static, bare_eq8, inertia = [], [], [], []
    fig = _figure((10.0, 4.0))
    ax, axs = fig.subplots(1, 2)
    for i, v in enumerate(speeds):
        rec = drags.inclined_penetration(ctx.world(), x0_m=2.4, length_m=0.45, alpha_rad=RAD(10), rake_rad=RAD(30),
                                         speed_m_s=float(v))
        bare, planner = _static(ctx, rec)
        sel = (rec.depth_m > 0.05) & (rec.depth_m < 0.07)
        world.append(float(rec.magnitude_n[sel].mean()))
        static.append(float(planner[sel].mean()))
        bare_eq8.append(float(bare[sel].mean()))
        inertia.append(float(inertial_force(rec.depth_m[sel], rec.rake_rad[sel], v, ctx.soil, ctx.width).mean()))
        ax.plot(rec.s_m, rec.magnitude_n, color=f"C{i}", lw=0.9, label=f"{v:g} m/s")
    ax.plot(rec.s_m, planner, "k-", lw=1.2, label="planner's model")
    ax.plot(rec.s_m, bare, "k--", lw=1.0, label=EQ8)
    ax.set_xlabel("distance along the 10 deg approach [m]")
    ax.set_ylabel("|F| [N]")
    ax.legend(fontsize=7)
    world, static, bare_eq8 = np.array(world), np.array(static), np.array(bare_eq8)
    dynamic = bare_eq8 + np.array(inertia)
    quad = np.polyfit(speeds, world, 2)
    axs.plot(speeds, world, "o-", label="world (5-7 cm deep)")
    axs.plot(speeds, static, "k-", lw=1.0, label="planner's model (static)")
    axs.plot(speeds, bare_eq8, "k--", label="eq. 8 (static)")
    axs.plot(speeds, dynamic, "k:", label="eq. 8 + inertia (dynamic FEE, McKyes 1985)")
    axs.set_xlabel("tool speed [m/s]")
    axs.set_ylabel("mean |F| at 5-7 cm depth [N]")
    axs.set_ylim(0, 1.15 * max(world.max(), static.max()))
    axs.legend(fontsize=7)
    fig.suptitle("Fig. 63: speed, alpha 10 deg, rho 30 deg; the world's speed effect is the inertia of the soil "
                 "entering the failing wedge (sand: no rate effect)", fontsize=9)
    _save(fig, path)
    at = {float(v): w for v, w in zip(speeds, world)}
    return (f"world {world[0]:.0f} N at {speeds[0]:g} m/s, {at[0.1]:.0f} N at 0.1, {at[0.5]:.0f} N at 0.5, "
            f"{world[-1]:.0f} N at {speeds[-1]:g} m/s (x{world[-1] / world[0]:.2f}); eq. 8 {bare_eq8.mean():.0f} N, "
            f"planner {static.mean():.0f} N; quadratic fit {quad[2]:.0f} + {quad[1]:.0f} v + {quad[0]:.0f} v^2 N; "
            f"eq. 8 + inertia {dynamic[0]:.0f} -> {dynamic[-1]:.0f} N")


def fig20(ctx: FigureContext, path: pathlib.Path) -> str:
    """Fig. 20: the tip-frame z force for rakes of 10, 15, 20 deg on a 10 deg approach (and 5 deg)."""
    fig = _figure((8.0, 4.0))
    ax = fig.add_subplot()
    peaks = []
    for i, r in enumerate((5, 10, 15, 20)):  # the thesis' three, and 5 deg (epsilon -5) where the world's bottom bears
        # entered at 2.0 m: a 5-10 deg rake is out of the wrist's reach further out
        rec = drags.inclined_penetration(ctx.world(), x0_m=2.0, length_m=0.4, alpha_rad=RAD(10), rake_rad=RAD(r))
        fz = rec.force_tip_n[:, 1]
        ax.plot(rec.s_m, fz, color=f"C{i}", label=f"rake {r} deg (epsilon {r - 10} deg)")
        steady = rec.s_m > ENTRY_M
        peaks.append((r, float(np.mean(fz[steady] > 0)), float(np.median(fz[steady]))))
    ax.axhline(0, color="k", lw=0.6)
    ax.set_yscale("symlog", linthresh=50.0)  # the bearing of rake 5 deg is ten times the others' cutting force
    ax.set_xlabel("distance along the 10 deg approach [m]")
    ax.set_ylabel("F_z in the tip frame [N] (+: the back bears; symlog)")
    ax.set_title("Fig. 20: alpha 10 deg; positive z force means contact at the back of the bucket", fontsize=9)
    ax.legend(fontsize=7)
    _save(fig, path)
    return "; ".join(f"rake {r}: F_z > 0 in {100 * share:.0f} % of samples past 8 cm, median {med:+.0f} N"
                     for r, share, med in peaks)


def _planner_figures() -> list[Figure]:
    from excavsim.studies.figures import plan as fp

    return [Figure("fig22", "rotation centres against pitch for several rates of rotation (bucket geometry)", fp.fig22),
            Figure("fig82", "two similar tip paths A and B (a planned dig and a shifted copy)", fp.fig82),
            Figure("fig83", "joint torques due to the tip forces measured along A, on A and on B", fp.fig83),
            Figure("fig84", "joint torques due to gravity along A and B", fp.fig84),
            Figure("fig85", "the force constraint's set in (k, alpha, d1) beside reachability's", fp.fig85),
            Figure("fig86", "geometric vs force-feasible sets in (alpha, d1, d2) at one k", fp.fig86),
            Figure("fig87", "where geometry and where force limits the dig (the `plan` figure)", fp.fig87),
            Figure("fig88", "digs chosen by least peak torque and by least cumulative torque", fp.fig88),
            Figure("fig91", "planning time per dig over three episodes (500/1000 N m, objectives)", fp.fig91)]


def _sensing_figures() -> list[Figure]:
    from excavsim.studies.figures import scale_dig as sd
    from excavsim.studies.figures import sensing as fs
    from excavsim.studies.figures import touchdown as td

    return [Figure("fig96", "range and reflectance images, edges, filtered pixels (testbed scanner)", fs.fig96),
            Figure("fig97", "an elevation map and its error; the 8-seed map-error table (testbed scanner)", fs.fig97),
            Figure("fig98", "ranges to four targets over 100 scans: noise about a slow drift", fs.fig98),
            Figure("fig99", "a 10 % range scale error on a profile, and the contact adjustment", fs.fig99),
            Figure("fig100", "a dig planned on a map with a range scale error: shallow as executed, too "
                             "aggressive on the contact-adjusted map; swept volumes", sd.fig100),
            Figure("fig102", "least-squares fit of measured against surveyed target ranges", fs.fig102),
            Figure("fig104", "touch-down on the nominal and the testbed arm: F/T and tip height against time",
                   td.fig104)]


def _learning_figures() -> list[Figure]:
    from excavsim.studies.figures import learning as fl

    return [Figure("fig68", "the one-dimensional example: eq. 18 with noise, data removed", fl.fig68),
            Figure("fig69", "global regression with linear, approximate and exact bases", fl.fig69),
            Figure("fig70", "3 nearest neighbours and LWR (narrow, wide, wide on eq. 21's basis)", fl.fig70),
            Figure("fig71", "LWR prediction time against inputs, time and error against data used", fl.fig71),
            Figure("fig72", "nets of 10 and 50 hidden units on x alone", fl.fig72),
            Figure("fig73", "a net of 5 hidden units on eq. 21's basis", fl.fig73),
            Figure("fig74", "F_x error against hidden units (held-out digs)", fl.fig74),
            Figure("fig75", "two exemplar digs: tip paths and measured forces", fl.fig75),
            Figure("fig76", "predictions on the exemplar digs: fitted wedge model", fl.fig76),
            Figure("fig77", "predictions on the exemplar digs: global regression", fl.fig77),
            Figure("fig78", "predictions on the exemplar digs: LWR", fl.fig78),
            Figure("fig79", "predictions on the exemplar digs: LWR scaled by importance", fl.fig79),
            Figure("fig80", "predictions on the exemplar digs: back propagation, 30 hidden units", fl.fig80)]


FORCE_FIGURES = [
    Figure("fig20", "tip-frame z force on a 10 deg approach for rakes 10, 15, 20 deg (world)", fig20),
    Figure("fig54", "force trace of one horizontal drag, 9-point smoothed, beside eq. 8 (world)", fig54),
    Figure("fig59", "force vs distance at 5, 10, 15 cm, 3 runs each, beside eq. 8 (world)", fig59),
    Figure("fig61", "force along a 10 deg approach for rakes 20-50 deg beside eq. 8 (world)", fig61),
    Figure("fig62", "failure-plane angle beta* and N_gamma against rake (wedge model)", fig62),
    Figure("fig63", "force against tool speed beside the static model (world)", fig63),
]


def figures() -> dict[str, Figure]:
    """Every figure by name, in the thesis' order."""
    table = {f.name: f for f in FORCE_FIGURES + _planner_figures() + _sensing_figures() + _learning_figures()}
    return dict(sorted(table.items(), key=lambda kv: int(kv[0][3:])))


def check_names(names: Sequence[str] | None) -> list[str]:
    """The figures to draw: ``names`` without repeats, or all of them for none.

    Raises:
        ExcavsimError: an unknown name (the message lists the known ones).
    """
    table = figures()
    names = list(dict.fromkeys(names or table))
    unknown = [n for n in names if n not in table]
    if unknown:
        raise ConfigError(f"unknown figure(s) {unknown}; allowed: {', '.join(table)} (or none for all)")
    return names


def write_figures(names: Sequence[str] | None, out: str | pathlib.Path, *, seed: int = 0,
                  progress: Callable[[str], None] | None = None) -> list[tuple[pathlib.Path, str]]:
    """Draw the named figures (all when ``names`` is empty or None) into ``out`` as ``NAME.png``.

    Returns:
        (path, summary) per figure, in the order drawn.

    Raises:
        ExcavsimError: an unknown name (the message lists the known ones).
    """
    table = figures()
    names = check_names(names)
    ctx = FigureContext(seed)
    out = pathlib.Path(out)
    done = []
    for name in names:
        path = out / f"{name}.png"
        summary = table[name].draw(ctx, path)
        done.append((path, summary))
        if progress:
            progress(f"{name}: {path}\n    {summary}")
    return done
