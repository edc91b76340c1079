"""The 2-D loading simulation of Singh 1995 §7.2.1 (Figs. 108-112) and its figures (Figs. 28-35).

A pile in a two-dimensional world (:mod:`excavsim.tasks.pile_loading.world.pile2d`), a machine
(:mod:`excavsim.robot.loaders`), and the loading planner (:mod:`excavsim.tasks.pile_loading.mind.planner`),
wired as the excavation cycle of Fig. 107:
the planner sees the terrain exactly (in simulation "a trivial task"), chooses a dig, the swept area is
removed, the pile settles to its angle of repose, and again, until no dig of minimal utility is left
(the pile is gone, or what is left is out of reach) or ``max_digs`` are spent.

* :func:`simulate_pile`: one run (Figs. 108, 109, 111), a row per dig;
* :func:`study`: Fig. 112: ``runs`` random piles per force limit, each run until ``remove_units`` are
  removed, both machines with the same capacity and force limit; the efficiency is the average
  removed per dig over the capacity;
* figures: :func:`figure_sequence` (the digs in the section, dark where soil was removed, the
  skeleton at the start, the end of the approach and the lift-out), :func:`figure_constraints` (each
  constraint's largest d1 over (alpha, k) per machine, the composite and the utility: Figs. 28-35),
  :func:`figure_study` (Fig. 112).

Configuration: ``configs/pile_loading_planar.yaml`` (:class:`LoadingConfig`); areas there are units of soil
(``units_m2``, 0.01 m^2: assumed), forces kN per metre of width.
"""

from __future__ import annotations

import dataclasses
import math
import pathlib

import numpy as np

from excavsim.errors import ConfigError
from excavsim.robot.loaders import FrontLoader, FrontShovel
from excavsim.tasks.pile_loading.config_planar import LOADING_MACHINES, LOADING_YAML, LoadingConfig, load_loading_config
from excavsim.tasks.pile_loading.mind import planner as lp
from excavsim.tasks.pile_loading.world.pile2d import Pile2D, random_pile, trapezoid_pile

CONFIG_PATH = LOADING_YAML
MACHINES = LOADING_MACHINES

# What §7.2.1 reports (its text), for the side-by-side tables.
THESIS = {
    "loader": {"capacity": 48.0, "digs": 13, "per_dig": 46.4, "efficiency": 0.95},
    "shovel": {"capacity": 27.0, "per_dig": 26.7, "efficiency": 0.95},
    "loader_force": {"capacity": 48.0, "per_dig": 32.3, "efficiency": 0.67},
}


# ---------------------------------------------------------------------------------------------- configuration
def make_machine(cfg: LoadingConfig, name: str) -> FrontLoader | FrontShovel:
    """The machine ``name`` (``loader`` or ``shovel``) of the configuration."""
    r = math.radians
    if name == "loader":
        m = cfg.machines.loader
        return FrontLoader(m.l1, m.l2, m.l3, m.l4, r(m.mu_deg),
                           np.array([m.d1_range[0], r(m.theta2_range_deg[0]), r(m.theta3_range_deg[0])]),
                           np.array([m.d1_range[1], r(m.theta2_range_deg[1]), r(m.theta3_range_deg[1])]),
                           m.wheel_front, m.floor)
    if name == "shovel":
        m = cfg.machines.shovel
        return FrontShovel(m.shoulder_height, m.l1, m.l2, m.l3, r(m.mu_deg),
                           np.radians([m.theta1_range_deg[0], m.theta2_range_deg[0], m.theta3_range_deg[0]]),
                           np.radians([m.theta1_range_deg[1], m.theta2_range_deg[1], m.theta3_range_deg[1]]),
                           m.track_front, m.floor)
    raise ConfigError(f"unknown machine {name!r} (allowed: {', '.join(MACHINES)})")


def make_rules(cfg: LoadingConfig, capacity_units: float, force_limit_kn_m: float | None = None, *,
               coarse: bool = False) -> lp.LoadingRules:
    """The planner's rules: the configured grid (the study's coarser one with ``coarse``), a capacity and a limit."""
    p, s = cfg.planner, cfg.study
    a0, a1, da = p.alpha_deg
    return lp.LoadingRules(
        k_max=p.k_max, k_min=p.k_min, k_step=s.k_step if coarse else p.k_step, alpha_min=math.radians(a0),
        alpha_max=math.radians(a1), alpha_step=math.radians(s.alpha_step_deg if coarse else da), d1_max=p.d1_max,
        d1_step=s.d1_step if coarse else p.d1_step, radii=tuple(p.radii), parameterization=p.parameterization,
        capacity=capacity_units * cfg.units_m2, min_fraction=p.min_fraction,
        exit_heading=math.radians(p.exit_heading_deg), base_backoffs=tuple(p.base_backoffs),
        force_limit=None if force_limit_kn_m is None else 1000.0 * force_limit_kn_m,
        unit_weight=1000.0 * cfg.soil.unit_weight_kn_m3, friction_deg=cfg.soil.friction_deg,
        cohesion=1000.0 * cfg.soil.cohesion_kpa)


def make_pile(cfg: LoadingConfig) -> Pile2D:
    """The pile of the single simulations (``pile`` in the configuration)."""
    p = cfg.pile
    return trapezoid_pile(p.height, p.top, p.foot, p.width, p.dx, p.repose_deg)


# ---------------------------------------------------------------------------------------------- the simulation
@dataclasses.dataclass
class PlanarDig:
    """One dig of a run: the plan's action, the area it swept (planned) and removed [m^2], its force [N/m]."""

    action: lp.LoadingAction
    planned_m2: float
    removed_m2: float
    force_n_m: float
    base_x: float
    before: np.ndarray
    after_cut: np.ndarray
    after_settle: np.ndarray


@dataclasses.dataclass
class Run:
    """A run: its digs, why it ended, the pile's area at the start and the end [m^2]."""

    machine: str
    capacity_m2: float
    digs: list[PlanarDig]
    reason: str
    start_m2: float
    end_m2: float
    xs: np.ndarray

    @property
    def removed_m2(self) -> float:
        return float(sum(d.removed_m2 for d in self.digs))

    def per_dig(self) -> float:
        return self.removed_m2 / len(self.digs) if self.digs else 0.0

    def efficiency(self) -> float:
        """Average removed per dig over the capacity (§7.2.1)."""
        return self.per_dig() / self.capacity_m2


def terrain_of(pile: Pile2D) -> lp.PileSection:
    """What the planner sees of the pile: the exact profile (§7.2: in simulation, perfect sensing)."""
    return lp.PileSection(pile.xs.copy(), pile.heights.copy(), pile.dx)


def simulate_pile(machine, rules: lp.LoadingRules, pile: Pile2D, *, name: str = "", max_digs: int = 100,
                  remove_m2: float | None = None, progress=None) -> Run:
    """Plan, remove the swept area, settle, repeat (see the module docstring); ``pile`` is changed in place.

    ``remove_m2`` ends the run once that much is removed (the study); otherwise it runs until no dig of
    minimal utility is left or ``max_digs`` are spent.
    """
    start = pile.area()
    digs: list[PlanarDig] = []
    reason = f"{max_digs} digs spent"
    for _ in range(max_digs):
        if remove_m2 is not None and sum(d.removed_m2 for d in digs) >= remove_m2 - 1e-9:
            reason = f"{remove_m2 / 0.01:.0f} units removed"
            break
        result = lp.plan(machine, terrain_of(pile), rules)
        if result.action is None:
            reason = "pile gone" if pile.area() < rules.min_fraction * rules.capacity else result.reason
            break
        before = pile.heights.copy()
        px, pz = lp.path_points(result.action, rules.exit_heading, pile.xs)
        removed = pile.carve(px, pz)
        cut = pile.heights.copy()
        pile.settle()
        digs.append(PlanarDig(result.action, result.volume, removed, result.force, result.base_x, before, cut,
                        pile.heights.copy()))
        if progress:
            progress(f"  dig {len(digs):3d}: k {result.action.k:.2f} m, alpha {math.degrees(result.action.alpha):5.1f} "
                     f"deg, d1 {result.action.d1:.2f} m, r {result.action.r:.2f} m: removed {removed:.3f} m^2")
    return Run(name, rules.capacity, digs, reason, start, pile.area(), pile.xs.copy())


def run_machine(cfg: LoadingConfig, name: str, *, force: bool = False, progress=None) -> Run:
    """Fig. 108 (loader) or 109 (shovel); with ``force`` Fig. 111's force constraint."""
    machine = make_machine(cfg, name)
    spec = cfg.machines.loader if name == "loader" else cfg.machines.shovel
    rules = make_rules(cfg, spec.capacity_units, cfg.fig111_force_limit_kn_m if force else None)
    return simulate_pile(machine, rules, make_pile(cfg), name=name, max_digs=cfg.planner.max_digs, progress=progress)


def study_run(cfg: LoadingConfig, name: str, force_kn_m: float, seed: int) -> tuple[int, float, str]:
    """One run of Fig. 112: the digs, the soil removed [m^2] and why the run ended."""
    s = cfg.study
    pile = random_pile(seed, s.pile_units * cfg.units_m2, foot=cfg.pile.foot, width=s.pile_width, dx=cfg.pile.dx,
                       repose_deg=cfg.pile.repose_deg)
    rules = make_rules(cfg, s.capacity_units, force_kn_m, coarse=True)
    run = simulate_pile(make_machine(cfg, name), rules, pile, name=name, max_digs=s.max_digs,
                   remove_m2=s.remove_units * cfg.units_m2)
    return len(run.digs), run.removed_m2, run.reason


def _study_job(args):
    path, name, force_kn_m, seed = args
    return study_run(load_loading_config(path), name, force_kn_m, seed)


def study(cfg_path: str | pathlib.Path | None = None, *, runs: int | None = None, workers: int = 1,
          seed: int = 0) -> dict:
    """Fig. 112: per machine and force limit, the efficiency over ``runs`` random piles (seeds seed, seed + 1, ...).

    Returns ``{"force_limits": [...], "runs": n, machine: {"efficiency": [...], "std": [...], "digs": [...]},
    "short": [(machine, force, seed, removed units, reason), ...]}``: ``short`` lists the runs that ended
    before ``remove_units`` were removed, and why.
    Deterministic for a seed: each run's pile comes from its seed alone, and the planner has no randomness.
    """
    cfg = load_loading_config(cfg_path)
    n = cfg.study.runs if runs is None else int(runs)
    if n < 1:
        raise ConfigError(f"the study needs at least one run; given {runs!r}")
    jobs = [(None if cfg_path is None else str(cfg_path), m, f, seed + i)
            for m in MACHINES for f in cfg.study.force_limits_kn_m for i in range(n)]
    if workers > 1:
        import multiprocessing
        with multiprocessing.get_context("spawn").Pool(workers) as pool:
            results = pool.map(_study_job, jobs, chunksize=1)
    else:
        results = [_study_job(j) for j in jobs]
    cap = cfg.study.capacity_units * cfg.units_m2
    out = {"force_limits": list(cfg.study.force_limits_kn_m), "runs": n, "short": []}
    target = cfg.study.remove_units * cfg.units_m2
    it = iter(zip(jobs, results))
    for m in MACHINES:
        eff, std, digs = [], [], []
        for _ in cfg.study.force_limits_kn_m:
            rs = [next(it) for _ in range(n)]
            e = np.array([removed / d / cap if d else 0.0 for _, (d, removed, _) in rs])
            eff.append(float(e.mean()))
            std.append(float(e.std()))
            digs.append(float(np.mean([d for _, (d, _, _) in rs])))
            out["short"] += [(m, f, sd, removed / cfg.units_m2, why) for (_, _, f, sd), (_, removed, why) in rs
                             if removed < target - 1e-9]
        out[m] = {"efficiency": eff, "std": std, "digs": digs}
    return out


# ---------------------------------------------------------------------------------------------- reports
def format_planar_run(run: Run, units_m2: float, exit_heading: float) -> str:
    """A run's digs as a table, in units of soil."""
    lines = [f"{'dig':>4} {'k m':>5} {'h m':>5} {'alpha':>6} {'d1 m':>5} {'r m':>5} {'d2 m':>5} {'planned':>8} "
             f"{'removed':>8} {'force kN/m':>10}"]
    for i, d in enumerate(run.digs, 1):
        a = d.action
        lines.append(f"{i:4d} {a.k:5.2f} {a.h:5.2f} {math.degrees(a.alpha):6.1f} {a.d1:5.2f} {a.r:5.2f} "
                     f"{a.d2(exit_heading):5.2f} {d.planned_m2 / units_m2:8.1f} {d.removed_m2 / units_m2:8.1f} "
                     f"{d.force_n_m / 1000:10.2f}")
    lines.append(f"{len(run.digs)} digs, {run.removed_m2 / units_m2:.1f} of {run.start_m2 / units_m2:.1f} units "
                 f"removed ({run.end_m2 / units_m2:.1f} left: {run.reason}); {run.per_dig() / units_m2:.1f} units "
                 f"per dig, efficiency {100 * run.efficiency():.0f} %")
    return "\n".join(lines)


def format_planar_comparison(rows: list[tuple[str, Run, dict]], units_m2: float) -> str:
    """The runs beside §7.2.1's numbers."""
    head = (f"{'run':<36} {'capacity':>8} {'digs':>5} {'thesis':>6} {'per dig':>8} {'thesis':>6} "
            f"{'efficiency':>10} {'thesis':>6}")
    lines = [head]
    for label, run, th in rows:
        lines.append(f"{label:<36} {run.capacity_m2 / units_m2:8.0f} {len(run.digs):5d} "
                     f"{str(th.get('digs', '-')):>6} {run.per_dig() / units_m2:8.1f} {th['per_dig']:6.1f} "
                     f"{100 * run.efficiency():9.0f}% {100 * th['efficiency']:5.0f}%")
    return "\n".join(lines)


def format_study(res: dict) -> str:
    """Fig. 112 as a table: efficiency (mean and standard deviation over the runs) per force limit."""
    lines = [f"Fig. 112: efficiency over {res['runs']} random piles per force limit (identical capacity and force)",
             f"{'force kN/m':>10} {'loader':>14} {'digs':>6} {'shovel':>14} {'digs':>6}"]
    for i, f in enumerate(res["force_limits"]):
        lo, sh = res["loader"], res["shovel"]
        lines.append(f"{f:10.1f} {100 * lo['efficiency'][i]:7.1f} ± {100 * lo['std'][i]:4.1f} {lo['digs'][i]:6.1f} "
                     f"{100 * sh['efficiency'][i]:7.1f} ± {100 * sh['std'][i]:4.1f} {sh['digs'][i]:6.1f}")
    short = res.get("short", [])
    lines.append(f"runs that ended before their target: {len(short)}")
    lines += [f"  {m} at {f:g} kN/m, seed {sd}: {units:.0f} units removed ({why})" for m, f, sd, units, why in short]
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------------- figures
def _figure(w, h):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(w, h))
    FigureCanvasAgg(fig)
    return fig


def _skeleton(machine, action: lp.LoadingAction, heights, xs, dx, rules, base_x):
    """The machine's skeleton (3, m, 2) at the start, the end of the approach and the end of the lift-out."""
    terrain = lp.PileSection(xs, heights, dx)
    poses, phase = lp.action_poses(action, terrain, rules, machine.floor)
    n_line = int(np.sum(phase == 0))
    picks = poses[[0, n_line - 1, -1]]
    if machine.moves_base:
        q, _ = machine.inverse(picks)
        return machine.points(q)
    q, _ = machine.inverse(picks, base_x)
    return machine.points(q, base_x)


def figure_sequence(run: Run, machine, rules: lp.LoadingRules, dx: float, path: pathlib.Path, title: str) -> None:
    """Figs. 108, 109, 111: one panel per dig: the section before it, the removed area dark, the skeleton thrice."""
    n = max(len(run.digs), 1)
    cols = min(n, 5)
    rows = int(math.ceil(n / cols))
    fig = _figure(3.2 * cols, 2.0 * rows + 0.6)
    xs = run.xs
    for i, d in enumerate(run.digs):
        ax = fig.add_subplot(rows, cols, i + 1)
        ax.fill_between(xs, 0, d.before, step="mid", color="#d8c39a", lw=0)
        ax.fill_between(xs, d.after_cut, d.before, step="mid", color="#3b2a14", lw=0)
        ax.plot(xs, d.after_settle, color="#7a5c2e", lw=0.8, drawstyle="steps-mid")
        px, pz = lp.path_points(d.action, rules.exit_heading)
        ax.plot(px, pz, color="k", lw=0.6, ls="--")
        try:
            sk = _skeleton(machine, d.action, d.before, xs, dx, rules, d.base_x)
            for j, c in enumerate(("#1f77b4", "#2ca02c", "#d62728")):
                ax.plot(sk[j, :, 0], sk[j, :, 1], "-o", color=c, ms=1.5, lw=1.0)
        except (ValueError, IndexError):
            pass
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_xlim(xs[0] - 5.0, xs[-1])
        ax.set_ylim(-0.2, 6.0)
        ax.set_aspect("equal")
        ax.set_title(f"dig {i + 1}: {d.removed_m2 / 0.01:.1f} units", fontsize=7)
        ax.tick_params(labelsize=5)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def figure_constraints(plans: dict[str, lp.LoadingPlan], path: pathlib.Path) -> None:
    """Figs. 28-35: per machine (rows), each constraint's largest d1 over (alpha, k) (white: none), the
    composite (Fig. 34) and the utility, the swept area of the composite's dig (Fig. 35)."""
    names = list(lp.LOADING_CONSTRAINTS) + ["composite", "utility"]
    fig = _figure(2.4 * len(names), 2.4 * len(plans) + 0.5)
    for row, (mname, p) in enumerate(plans.items()):
        ext = [math.degrees(p.grid_alpha[0]), math.degrees(p.grid_alpha[-1]), p.grid_k[0], p.grid_k[-1]]
        for col, c in enumerate(names):
            ax = fig.add_subplot(len(plans), len(names), row * len(names) + col + 1)
            if c == "composite":
                data, label, cmap = p.d1[..., 0], "d1 [m]", "viridis"
            elif c == "utility":
                data, label, cmap = p.cell_volume[..., 0] / 0.01, "units", "gray"
            else:
                data, label, cmap = p.d1_max[c][..., 0], "d1 [m]", "viridis"
            im = ax.imshow(data, origin="lower", aspect="auto", extent=ext, cmap=cmap)
            fig.colorbar(im, ax=ax, fraction=0.05).ax.tick_params(labelsize=5)
            ax.set_title(f"{mname}: {c}", fontsize=7)
            ax.set_xlabel("alpha [deg]", fontsize=6)
            ax.set_ylabel("k [m] from the foot", fontsize=6)
            ax.tick_params(labelsize=5)
            _ = label
    fig.suptitle("the loading action space (Figs. 28-35): largest d1 each constraint allows, composite, utility",
                 fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def figure_study(res: dict, path: pathlib.Path) -> None:
    """Fig. 112: efficiency against the force available, both machines."""
    fig = _figure(5.0, 3.6)
    ax = fig.add_subplot(1, 1, 1)
    f = res["force_limits"]
    for m, style in (("loader", "-o"), ("shovel", "-s")):
        ax.errorbar(f, 100 * np.array(res[m]["efficiency"]), yerr=100 * np.array(res[m]["std"]), fmt=style,
                    capsize=3, label=f"front {m}")
    ax.set_xlabel("force available [kN per m of width]")
    ax.set_ylabel("efficiency [%] (per dig / capacity)")
    ax.set_title(f"Fig. 112: {res['runs']} random piles per force limit", fontsize=9)
    ax.set_ylim(0, 105)
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def write_study(cfg_path: str | pathlib.Path | None, out: str | pathlib.Path, *, runs: int | None = None,
                workers: int = 1, seed: int = 0, say=print) -> None:
    """``excavsim load --study``: Fig. 112 (efficiency against the force limit over random piles, both
    machines) into ``out/fig112.png`` and ``fig112.txt``, saying the table.

    Args:
        cfg_path: the loading configuration (default ``configs/pile_loading_planar.yaml``).
        runs: runs per force limit and machine (default the configuration's).
        workers: processes.
        seed: the first random pile's seed.
    """
    cfg = load_loading_config(cfg_path)
    out = pathlib.Path(out)
    out.mkdir(parents=True, exist_ok=True)
    say(f"excavsim load --study: Fig. 112, {runs or cfg.study.runs} runs per force limit and machine, "
        f"each removing {cfg.study.remove_units:.0f} units from a random pile")
    res = study(cfg_path, runs=runs, workers=workers, seed=seed)
    table = format_study(res)
    (out / "fig112.txt").write_text(table + "\n")
    figure_study(res, out / "fig112.png")
    say(table)
    say(f"wrote {out / 'fig112.png'}, {out / 'fig112.txt'}")


def write_planar_figures(cfg: LoadingConfig, out: str | pathlib.Path, *, machine: str | None = None, say=print) -> None:
    """``excavsim load``: the 2-D loading runs of §7.2.1 (Figs. 108, 109 and, for the loader, 111
    with the force limit) and the constraints of both machines, written as figures and tables into
    ``out`` and compared with the thesis' numbers.

    Args:
        cfg: the loading configuration.
        machine: one of :data:`MACHINES` (default both).
        say: where the runs and the comparison go.
    """
    out = pathlib.Path(out)
    out.mkdir(parents=True, exist_ok=True)
    u = cfg.units_m2
    names = [machine] if machine else list(MACHINES)
    rows, paths = [], []
    plans = {}
    for name in MACHINES:
        spec = getattr(cfg.machines, name)
        plans[name] = lp.plan(make_machine(cfg, name), terrain_of(make_pile(cfg)), make_rules(cfg, spec.capacity_units))
    figure_constraints(plans, out / "constraints.png")
    paths.append(out / "constraints.png")
    runs = [(n, False) for n in names] + ([("loader", True)] if "loader" in names else [])
    for name, force in runs:
        fig, key = {("loader", False): ("fig108", "loader"), ("shovel", False): ("fig109", "shovel"),
                    ("loader", True): ("fig111", "loader_force")}[(name, force)]
        label = f"{fig} front {name}" + (f", force <= {cfg.fig111_force_limit_kn_m:g} kN/m" if force else "")
        say(f"{label}:")
        run = run_machine(cfg, name, force=force)
        spec = getattr(cfg.machines, name)
        rules = make_rules(cfg, spec.capacity_units, cfg.fig111_force_limit_kn_m if force else None)
        say(format_planar_run(run, u, rules.exit_heading))
        figure_sequence(run, make_machine(cfg, name), rules, cfg.pile.dx, out / f"{fig}.png", label)
        (out / f"{fig}.txt").write_text(format_planar_run(run, u, rules.exit_heading) + "\n")
        paths += [out / f"{fig}.png", out / f"{fig}.txt"]
        rows.append((label, run, THESIS[key]))
    table = format_planar_comparison(rows, u)
    (out / "comparison.txt").write_text(table + "\n")
    say("\nbeside the thesis (§7.2.1; 1 unit of soil = %g m^2 of the section):" % u)
    say(table)
    say("wrote " + ", ".join(str(p) for p in paths + [out / "comparison.txt"]))
