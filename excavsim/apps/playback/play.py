"""The chapter-6 experiment (DiMaio 1998 §6.1-6.3, Figs. 6.42-6.48): demonstrate a dig
in one soil, play it back in a stiffer and a softer one with each impedance controller.

The demonstration is the cut of :data:`~excavsim.handoff.dig.DEMO_ACTION` recorded by the dig executor
in the demonstration soil (world model ``dimaio``); a 10 cm free-motion descent onto the entry is
prepended (:meth:`~excavsim.execution.playback.Demonstration.with_approach`) so that the variable
impedance shows its switch from the air to the soil. Each playback runs in a fresh world with the
same seed: the arm goes home, to the approach pose, and then
:class:`~excavsim.execution.playback.ImpedancePlayback` runs at the control rate.

The playback soils are Table 6.4's kind of change of the demonstration soil's DiMaio parameters
(assumed factors, :data:`STIFFER` and :data:`SOFTER`): every viscous, stiffness, shear and
accumulation term scaled up (down). The controllers (:func:`controllers`) use Table 6.5's mass
(100 kg), stiffness range (1e3 - 1e5 N/m) and damping factor (1.0): fixed high, moderate (Fig. 6.44)
and low impedance, and the variable one, eq. 3.37 with G = 2000 (:data:`G_VARIABLE`) and the
:class:`~excavsim.execution.playback.DepthDual` depth law; the velocity weighting G is swept as in
Figs. 6.46-6.48 (low, high, and the thesis' medium G = 1000), with two ablations (eq. 3.37 alone, the
depth law on position control). Printed and written: the errors per soil and controller (position RMS,
force RMS, eq. 3.14's E) with a closing note (:func:`verdict`), ``errors.csv``, ``errors.png``, ``sweep.png``, the
Figs. 3.7-3.10 analysis of §3.3.1 (``duality.png``, :func:`plot_duality`) and one Figs. 6.42-6.48
figure per soil and controller. A given demonstration (``--demo``: teleoperated, or read from a
recording) replaces the recorded one. :func:`run_seeds` runs the experiment over several seeds
(``--seeds``) and prints each soil's and controller's errors per seed with their mean
(:func:`seed_table`) and a closing note counting the seeds on which the variable controller wins
(:func:`seed_verdict`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np

from excavsim.config import SoilParams, get_soil, load_scene_config
from excavsim.errors import ConfigError, GoalError
from excavsim.execution.playback import (DepthDual, Demonstration, FixedImpedance, ImpedancePlayback, PlaybackRun,
                                         VariableImpedance, demonstration_from_joints, demonstration_from_record)
from excavsim.handoff.dig import DigPlan
from excavsim.handoff.maps import ElevationMap
from excavsim.handoff.dig import DEMO_ACTION
from excavsim.rig.core import go_home, go_to, make_rig
from excavsim.world.simulation import Simulation

DEMO_SOIL = "testbed_sand"
# Table 6.4's kind of change (assumed factors): the playback soil is harder (softer) in every term
SCALED = ("viscous_tangential_n_s_m2", "viscous_normal_n_s_m2", "viscous_angular_n_s", "stiffness_n_m",
          "angular_stiffness_nm_rad", "shear_strength_pa", "accumulation_n_m3")
STIFFER, SOFTER = 3.0, 0.3
MASS, K_MIN, K_MAX = 100.0, 1.0e3, 1.0e5  # Table 6.5
K_MODERATE = 1.0e4  # Fig. 6.44's moderate fixed impedance (B = 2000 N s/m)
W = 1.0e6  # §3.3.1: 1 mm of position error weighs as 1 N of force error (for the printed E)
G_SWEEP = {"low G": 100.0, "high G": 100000.0, "medium G": 1000.0}  # Figs. 6.46, 6.47, 6.48 (§6.3: "800 to 1000")
# The chapter's variable controller: eq. 3.37 with the DepthDual shift and the velocity weighting G chosen as the
# position-force weighting of §3.3.2 is meant to be chosen, by the error it weights: of G in {1000, 2000, 3000, 5000,
# 1e4} (G is "similar in concept to W", §3.3.4), 2000 gave the least mean eq. 3.14 E (W = 1e6) in each of the three
# soils on seeds 0-3 (same 13 k, stiffer 190 k, softer 215 k; G = 1000: 33, 218, 227 k), checked on seeds 4-7 and
# 8-15 (README). The thesis' 800-1000 is for its machine and soils; the demonstration's own force/velocity ratio is
# about 8600 N s/m here, so G = 1000 reads it as a hard contact (r ~ 9, K ~ 6e3 N/m) even in the unchanged soil.
G_VARIABLE = 2000.0
VARIABLE = f"variable (G={G_VARIABLE:g})"
POSITION, FORCE = "position (high K)", "force (low K)"


def scaled_soil(name: str, factor: float) -> SoilParams:
    """Soil ``name`` with its DiMaio stiffness/viscous/shear/accumulation terms times ``factor``."""
    soil = get_soil(name)
    dm = soil.dimaio
    return soil.model_copy(update={"dimaio": dm.model_copy(update={k: getattr(dm, k) * factor for k in SCALED})})


def make_world(soil: SoilParams, seed: int) -> Simulation:
    scene = load_scene_config()
    scene = scene.model_copy(update={"truth": scene.truth.model_copy(update={"model": "dimaio"})})
    return Simulation(scene=scene, soil=soil, seed=seed)


def controllers(sweep: bool = True) -> list:
    """The fixed high, moderate and low impedances (Figs. 6.42-6.44) and the variable one (eq. 3.37 with
    the :class:`~excavsim.execution.playback.DepthDual` depth); with ``sweep`` also the velocity-weighting
    sweep (Figs. 6.46-6.48) and two ablations: eq. 3.37 without the depth law, the depth law on position
    control."""
    laws = [FixedImpedance(POSITION, MASS, K_MAX), FixedImpedance("moderate (K=1e4)", MASS, K_MODERATE),
            FixedImpedance(FORCE, MASS, K_MIN),
            VariableImpedance(VARIABLE, MASS, K_MIN, K_MAX, G_VARIABLE, depth=DepthDual(w=W))]
    if sweep:
        laws += [VariableImpedance(sweep_name(g), MASS, K_MIN, K_MAX, g, depth=DepthDual(w=W))
                 for g in G_SWEEP.values()]
        laws += [VariableImpedance(f"eq. 3.37 only (G={G_VARIABLE:g})", MASS, K_MIN, K_MAX, G_VARIABLE),
                 FixedImpedance("position + depth", MASS, K_MAX, depth=DepthDual(w=W))]
    return laws


def sweep_name(g: float) -> str:
    """The name of the variable controller with velocity weighting ``g`` in the sweep (Figs. 6.46-6.48)."""
    key = next(k for k, v in G_SWEEP.items() if v == g)
    return f"variable ({key}={g:g})"


def demo_plan(sim: Simulation, rig) -> DigPlan:
    """The plan of :data:`DEMO_ACTION` on the flat fill (the fill's height is read from the world,
    privileged, only to lay out the demonstration dig)."""
    z = float(np.median(sim.soil.grid.heights))
    emap = ElevationMap(0.55, -1.5, 0.05, np.full((60, 60), z), np.ones((60, 60), bool), 0.0)
    surface = rig.planner.surface(emap)
    poses, phases = rig.planner.trajectory(DEMO_ACTION, surface)
    return DigPlan(poses, phases, math.radians(rig.goal.waist_deg), rig.planner.swept_volume(poses, surface))


def record_demonstration(seed: int = 0, soil: str = DEMO_SOIL) -> Demonstration:
    """Dig :data:`DEMO_ACTION` with the executor in ``soil`` and take its cut as the demonstration."""
    sim = make_world(get_soil(soil), seed)
    rig = make_rig(sim, seed=seed)
    go_home(sim, rig)
    plan = demo_plan(sim, rig)
    waist = plan.waist
    rec = rig.executor.run(plan)
    return demonstration_from_record(rec, arm=rig.arm, ft=rig.executor.ft, waist=waist, dt=sim.control_dt,
                                     source=f"executor record of {DEMO_ACTION} ({rec.outcome})", soil=soil)


def play(demo: Demonstration, soil: SoilParams, label: str, law, seed: int = 0) -> PlaybackRun:
    """One playback of ``demo`` in a fresh world of ``soil`` with impedance ``law``."""
    return play_in_world(demo, soil, label, law, seed)[0]


def play_in_world(demo: Demonstration, soil: SoilParams, label: str, law, seed: int = 0) -> tuple[PlaybackRun, Simulation]:
    """:func:`play`, and the world it played in (for its privileged end state, e.g. the soil in the bucket)."""
    sim = make_world(soil, seed)
    rig = make_rig(sim, seed=seed)
    go_home(sim, rig)
    q = rig.home.copy()
    q[0] = demo.waist
    q[1:4], ok = rig.arm.inverse(demo.pose[0])
    if not ok:
        raise GoalError(f"playback: the demonstration's first pose {np.round(demo.pose[0], 3).tolist()} (x, z [m], "
                        "pitch [rad]) is out of the arm's reach")
    go_to(sim, q, rig.executor_cfg)
    return ImpedancePlayback(sim, rig.arm, rig.executor.ft, law).run(demo, soil=label), sim


def demonstration_from_signals(joint_times: np.ndarray, joints: np.ndarray, ft_times: np.ndarray,
                               ft_tip: np.ndarray, path_world: np.ndarray, *, source: str,
                               soil: str = "") -> Demonstration:
    """A demonstration from a dig's sampled joints and F/T readings (e.g. read back from a recording by
    :func:`excavsim.record.demo_reading.read_dig`), with the robot's model of itself from the scene."""
    sim = make_world(get_soil(DEMO_SOIL), 0)
    rig = make_rig(sim)
    return demonstration_from_joints(joint_times, joints, ft_times, ft_tip, path_world, arm=rig.arm,
                                     ft=rig.executor.ft, dt=sim.control_dt, source=source, soil=soil)


def run_playback(out: Path | None = None, *, seed: int = 0, sweep: bool = True, demo: Demonstration | None = None,
                 progress: Callable[[str], None] = print) -> dict:
    """The experiment (see the module docstring); returns ``{(soil, controller): errors}`` and writes
    the demonstration, the plots and the error table into ``out``.

    Args:
        demo: a demonstration to play back instead of recording :data:`DEMO_ACTION` (its first pose is
            reached by a joint move; no approach is prepended).
    """
    if demo is None:
        demo = record_demonstration(seed)
        progress(f"demonstration: {len(demo.times)} samples ({demo.times[-1]:.2f} s) in {demo.soil}; "
                 f"{demo.source}")
        demo = demo.with_approach(0.10, 1.0)
    else:
        progress(f"demonstration given: {len(demo.times)} samples ({demo.times[-1]:.2f} s), soil {demo.soil!r}, "
                 f"{demo.source}; the 'same' soil is {DEMO_SOIL} under DiMaio's model")
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        demo.save(out / "demonstration.json")
    soils = {"same": get_soil(DEMO_SOIL), f"stiffer x{STIFFER:g}": scaled_soil(DEMO_SOIL, STIFFER),
             f"softer x{SOFTER:g}": scaled_soil(DEMO_SOIL, SOFTER)}
    runs: dict[tuple[str, str], PlaybackRun] = {}
    table = {}
    progress(f"{'soil':12s} {'controller':24s} {'pos RMS/max [cm]':>17s} | {'force RMS/max err [N]':>21s} "
             f"{'peak [N]':>8s} | {'E = mean W x~^2 + f~^2':>22s}")
    for label, soil in soils.items():
        for law in controllers(sweep and label != "same"):
            run = play(demo, soil, label, law, seed)
            runs[label, law.name] = run
            e = table[label, law.name] = run.errors(W)
            progress(f"{label:12s} {law.name:24s} {100 * e['pos_rms_m']:7.2f} / {100 * e['pos_max_m']:6.2f}  | "
                     f"{e['force_rms_n']:8.1f} / {e['force_max_err_n']:8.1f}   {e['force_peak_n']:8.1f} | "
                     f"{e['weighted_error']:22.0f}" + ("" if run.outcome == "completed" else f" | {run.outcome}"))
    progress(f"(demonstrated force peak {table['same', POSITION]['demo_force_peak_n']:.0f} N; W = {W:g})")
    for line in verdict(table, [k for k in soils if k != "same"]):
        progress(line)
    if out is not None:
        _plot(runs, out)
        _plot_errors(table, out / "errors.png")
        if sweep:
            _plot_sweep(table, [k for k in soils if k != "same"], out / "sweep.png")
            plot_duality(out / "duality.png")
        lines = ["soil,controller,pos_rms_m,pos_max_m,force_rms_n,force_max_err_n,force_peak_n,weighted_error"]
        lines += [f"{s},{c},{e['pos_rms_m']:.4f},{e['pos_max_m']:.4f},{e['force_rms_n']:.1f},"
                  f"{e['force_max_err_n']:.1f},{e['force_peak_n']:.1f},{e['weighted_error']:.0f}"
                  for (s, c), e in table.items()]
        (out / "errors.csv").write_text("\n".join(lines) + "\n")
        extra = ", sweep.png, duality.png" if sweep else ""
        progress(f"wrote {out}/demonstration.json, errors.csv, errors.png{extra} and a figure per soil and controller")
    return table


MAX_SEEDS = 64  # a bound on --seeds (each seed is a whole experiment, about 8 s of CPU without the sweep)


def seed_range(text: str) -> list[int]:
    """The seeds of ``--seeds``: ``"0-7"``, ``"0,2,5"``, ``"3"`` or a mix (``"0-3,9"``), each in [0, 2**31).

    Raises:
        ExcavsimError: naming the bad part and the allowed forms.
    """
    allowed = "allowed: seeds N (0 <= N < 2**31) as 'A-B', 'A,B,C' or a mix such as '0-3,9'"
    seeds: list[int] = []
    for part in str(text).split(","):
        lo, sep, hi = part.strip().partition("-")
        try:
            a, b = int(lo), int(hi) if sep else int(lo)
        except ValueError:
            raise ConfigError(f"--seeds: {part.strip()[:40]!r} is not a seed or a range; {allowed}") from None
        if not 0 <= a <= b < 2 ** 31:
            raise ConfigError(f"--seeds: {part.strip()[:40]!r} is not an increasing range of seeds; {allowed}")
        if len(seeds) + b - a >= MAX_SEEDS:
            raise ConfigError(f"--seeds: more than {MAX_SEEDS} seeds given; {allowed}")
        seeds += [s for s in range(a, b + 1) if s not in seeds]
    return seeds


METRICS = (("pos_rms_m", 100.0, "position RMS [cm]", "{:7.2f}"), ("force_rms_n", 1.0, "force RMS error [N]", "{:7.0f}"),
           ("weighted_error", 1e-3, "E = mean W x~^2 + f~^2 [1e3]", "{:7.0f}"))


def seed_table(tables: dict[int, dict]) -> list[str]:
    """Per soil and metric (position RMS, force RMS error, E) a table of controllers against seeds, with the mean
    over the seeds; ``tables`` is ``{seed: run_playback's table}``."""
    seeds = list(tables)
    keys = list(dict.fromkeys(k for t in tables.values() for k in t))
    lines = []
    for soil in dict.fromkeys(s for s, _ in keys):
        names = [c for s, c in keys if s == soil]
        for key, scale, label, fmt in METRICS:
            lines.append(f"{soil}: {label}")
            lines.append(f"  {'controller':24s}" + "".join(f"{'seed ' + str(s):>9s}" for s in seeds) + f"{'mean':>9s}")
            for name in names:
                vals = [scale * tables[s][soil, name][key] for s in seeds]
                lines.append(f"  {name:24s}" + "".join("  " + fmt.format(v) for v in vals)
                             + "  " + fmt.format(float(np.mean(vals))))
    return lines


def seed_verdict(tables: dict[int, dict], soils: list[str]) -> list[str]:
    """The closing note over seeds: in each changed soil, on how many seeds the variable controller's E, position
    and force errors are below those of position control (high K) and of the low fixed impedance, with the means.

    What ch. 6 claims (§6.2-6.3, ch. 7) is the compromise: position control keeps the path and loses the force,
    the low impedance keeps the force and loses the path, and the variable impedance controls both "in favour of
    position control" (Fig. 6.48); both errors below *both* fixed extremes is the stricter reading of issue 24."""
    seeds, n = list(tables), len(tables)
    lines = []
    for soil in soils:
        v, p, f = ({s: tables[s][soil, c] for s in seeds} for c in (VARIABLE, POSITION, FORCE))

        def below(key, other):
            return sum(v[s][key] < other[s][key] for s in seeds)

        def mean(d, key, scale=1.0):
            return scale * float(np.mean([d[s][key] for s in seeds]))

        e_wins = sum(v[s]["weighted_error"] < min(p[s]["weighted_error"], f[s]["weighted_error"]) for s in seeds)
        both = sum(v[s]["pos_rms_m"] < min(p[s]["pos_rms_m"], f[s]["pos_rms_m"])
                   and v[s]["force_rms_n"] < min(p[s]["force_rms_n"], f[s]["force_rms_n"]) for s in seeds)
        lines.append(
            f"{soil} over {n} seeds: {VARIABLE} E lower than both fixed extremes on {e_wins}/{n} "
            f"(mean {mean(v, 'weighted_error', 1e-3):.0f} k vs position {mean(p, 'weighted_error', 1e-3):.0f} k, low K "
            f"{mean(f, 'weighted_error', 1e-3):.0f} k); position RMS below low K's on {below('pos_rms_m', f)}/{n}, "
            f"below position control's on {below('pos_rms_m', p)}/{n} (mean {mean(v, 'pos_rms_m', 100):.1f} cm vs "
            f"{mean(p, 'pos_rms_m', 100):.1f}, {mean(f, 'pos_rms_m', 100):.1f}); force RMS below position control's on "
            f"{below('force_rms_n', p)}/{n}, below low K's on {below('force_rms_n', f)}/{n} (mean "
            f"{mean(v, 'force_rms_n'):.0f} N vs {mean(p, 'force_rms_n'):.0f}, {mean(f, 'force_rms_n'):.0f}); "
            f"both errors below both extremes on {both}/{n}")
    return lines


def run_seeds(seeds: list[int], out: Path | None = None, *, sweep: bool = False, demo: Demonstration | None = None,
              progress: Callable[[str], None] = print) -> dict[int, dict]:
    """The experiment of :func:`run_playback` on each of ``seeds`` (each seed records its own demonstration
    unless ``demo`` is given, and replays it in worlds of that seed), then :func:`seed_table` and
    :func:`seed_verdict`; writes ``seeds.csv`` into ``out``. Returns ``{seed: table}``."""
    if not seeds:
        raise ConfigError("run_seeds: no seeds given")
    tables = {}
    for s in seeds:
        tables[s] = run_playback(None, seed=s, sweep=sweep, demo=demo, progress=lambda line: None)
        v = {soil: e for (soil, c), e in tables[s].items() if c == VARIABLE}
        progress(f"seed {s}: {VARIABLE} " + ", ".join(f"{soil} {100 * e['pos_rms_m']:.1f} cm / {e['force_rms_n']:.0f} N"
                                                       for soil, e in v.items()))
    for line in seed_table(tables):
        progress(line)
    changed = [soil for soil in dict.fromkeys(s for s, _ in tables[seeds[0]]) if soil != "same"]
    for line in seed_verdict(tables, changed):
        progress(line)
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        lines = ["seed,soil,controller,pos_rms_m,pos_max_m,force_rms_n,force_max_err_n,force_peak_n,weighted_error"]
        lines += [f"{seed},{s},{c},{e['pos_rms_m']:.4f},{e['pos_max_m']:.4f},{e['force_rms_n']:.1f},"
                  f"{e['force_max_err_n']:.1f},{e['force_peak_n']:.1f},{e['weighted_error']:.0f}"
                  for seed, t in tables.items() for (s, c), e in t.items()]
        (out / "seeds.csv").write_text("\n".join(lines) + "\n")
        progress(f"wrote {out}/seeds.csv")
    return tables


def verdict(table: dict, soils: list[str]) -> list[str]:
    """The closing note: per changed soil, whether the variable controller's E, position and force
    errors are below each fixed extreme's."""
    lines = []
    for soil in soils:
        v, p, f = (table[soil, c] for c in (VARIABLE, POSITION, FORCE))
        wins = v["weighted_error"] < min(p["weighted_error"], f["weighted_error"])
        lines.append(
            f"{soil}: {VARIABLE} E {v['weighted_error']:.0f} vs position {p['weighted_error']:.0f}, force "
            f"{f['weighted_error']:.0f} -> {'lower than both' if wins else 'NOT lower than both'}; "
            f"position RMS {100 * v['pos_rms_m']:.1f} cm (position control {100 * p['pos_rms_m']:.1f}, low K "
            f"{100 * f['pos_rms_m']:.1f}), force RMS error {v['force_rms_n']:.0f} N (position control "
            f"{p['force_rms_n']:.0f}, low K {f['force_rms_n']:.0f})")
    return lines


def _slug(text: str) -> str:
    return "".join(c if c.isalnum() else "_" for c in text).strip("_")


def _plot(runs: dict[tuple[str, str], PlaybackRun], out: Path) -> None:
    """Figs. 6.42-6.48's layout: per soil and controller, x, z, the two forces and the stiffness against time."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    for (soil, name), run in runs.items():
        fig, ax = plt.subplots(5, 1, figsize=(7, 10), sharex=True)
        t = run.times
        for k, lab in enumerate(("x [m]", "z [m]")):
            ax[k].plot(t, run.desired_pose[:, k], "k--", label="desired (demonstration)")
            ax[k].plot(t, run.pose[:, k], "C0", label="actual")
            ax[k].set_ylabel(lab)
        if run.depth is not None:
            ax[1].plot(t, run.desired_pose[:, 1] - run.depth, "C2:", label="demonstration + depth shift")
            ax[1].legend(fontsize=8)
        for k, lab in enumerate(("F radial [N]", "F vertical [N]")):
            ax[2 + k].plot(t, run.desired_force[:, k], "k--")
            ax[2 + k].plot(t, run.force[:, k], "C1")
            ax[2 + k].set_ylabel(lab)
        ax[4].semilogy(t, run.stiffness[:, 0], label="K x")
        ax[4].semilogy(t, run.stiffness[:, 1], label="K z")
        ax[4].set_ylabel("K [N/m]")
        ax[4].set_xlabel("time [s]")
        ax[0].legend(fontsize=8)
        ax[4].legend(fontsize=8)
        fig.suptitle(f"playback in {soil} soil: {name}")
        fig.tight_layout()
        fig.savefig(out / f"playback_{_slug(f'{soil}_{name}')}.png", dpi=80)
        plt.close(fig)


def _plot_errors(table: dict, path: Path) -> None:
    """Position RMS, force RMS error and E per controller, one group of bars per soil."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    soils = list(dict.fromkeys(s for s, _ in table))
    names = list(dict.fromkeys(c for _, c in table))
    fig, ax = plt.subplots(3, 1, figsize=(10, 9), sharex=True)
    width = 0.8 / len(names)
    for j, name in enumerate(names):
        xs = [i + (j - len(names) / 2 + 0.5) * width for i, s in enumerate(soils) if (s, name) in table]
        es = [table[s, name] for s in soils if (s, name) in table]
        for k, (key, scale) in enumerate((("pos_rms_m", 100.0), ("force_rms_n", 1.0), ("weighted_error", 1e-3))):
            ax[k].bar(xs, [scale * e[key] for e in es], width, label=name if k == 0 else None, color=f"C{j % 10}")
    for a, lab in zip(ax, ("position RMS [cm]", "force RMS error [N]", "E = mean(W x~^2 + f~^2) [1e3]")):
        a.set_ylabel(lab)
    ax[2].set_yscale("log")
    ax[2].set_xticks(range(len(soils)), soils)
    ax[0].legend(fontsize=7, ncol=3)
    fig.suptitle(f"playback errors against the demonstration (W = {W:g})")
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def _plot_sweep(table: dict, soils: list[str], path: Path) -> None:
    """The velocity-weighting sweep of Figs. 6.46-6.48: the variable controller's errors against G, with the
    fixed impedances' as horizontal lines."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    gs = sorted([*G_SWEEP.values(), G_VARIABLE])
    names = {g: VARIABLE if g == G_VARIABLE else sweep_name(g) for g in gs}
    fig, ax = plt.subplots(3, len(soils), figsize=(5 * len(soils), 8), squeeze=False, sharex=True)
    for c, soil in enumerate(soils):
        for r, (key, scale, lab) in enumerate((("pos_rms_m", 100.0, "position RMS [cm]"),
                                               ("force_rms_n", 1.0, "force RMS error [N]"),
                                               ("weighted_error", 1e-3, "E [1e3]"))):
            a = ax[r, c]
            a.semilogx(gs, [scale * table[soil, names[g]][key] for g in gs], "o-", color="C3",
                       label="variable + depth")
            for j, fixed in enumerate((POSITION, "moderate (K=1e4)", FORCE)):
                a.axhline(scale * table[soil, fixed][key], color=f"C{j}", ls="--", label=fixed)
            a.set_ylabel(lab)
        ax[0, c].set_title(soil)
        ax[-1, c].set_xlabel("velocity weighting G [N s/m] (eq. 3.37)")
    ax[0, 0].legend(fontsize=7)
    fig.suptitle(f"velocity-weighting sweep (Figs. 6.46-6.48: G = 100, 1000, 1e5; the chapter's G = {G_VARIABLE:g})")
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


W_DUALITY = 1.0e9  # the weighting at which Figs. 3.7-3.10's dampings (1-6 kN s/m) come out (the figures do not say)


def plot_duality(path: Path) -> None:
    """Figs. 3.7-3.10: the damping minimising eq. 3.25 (§3.3.1, :func:`~excavsim.execution.duality.optimal_damping`)
    against environment stiffness, environment damping, machine mass and the desired trajectories' bandwidth."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from excavsim.execution.duality import optimal_damping

    def bm(mm=110.0, be=500.0, ke=39000.0, f3db=20.0):
        return optimal_damping(mm, be, ke, f3db_hz=f3db, w=W_DUALITY)

    fig, ax = plt.subplots(2, 2, figsize=(10, 7))
    kes, bes, mms, bws = (np.linspace(5e3, 5e4, 10), np.linspace(50, 600, 10), np.linspace(100, 900, 9),
                          np.linspace(2, 100, 10))
    for mm in (110.0, 500.0, 960.0):
        ax[0, 0].plot(kes, [bm(mm=mm, ke=k) for k in kes], label=f"Mm = {mm:g} kg")
        ax[0, 1].plot(bes, [bm(mm=mm, be=b) for b in bes], label=f"Mm = {mm:g} kg")
    for ke in (1.5e4, 3.9e4):
        ax[1, 0].plot(mms, [bm(mm=m, ke=ke) for m in mms], label=f"Ke = {ke:g} N/m")
    ax[1, 1].plot(bws, [bm(mm=100.0, ke=1e4, f3db=f) for f in bws], label="Mm = 100 kg, Ke = 1e4 N/m")
    for a, (xl, title) in zip(ax.flat, (("Ke [N/m] (Be = 500 N s/m)", "Fig. 3.7"),
                                        ("Be [N s/m] (Ke = 39000 N/m)", "Fig. 3.8"),
                                        ("Mm [kg] (Be = 500 N s/m)", "Fig. 3.9 (against machine mass)"),
                                        ("f3dB [Hz] (Be = 500 N s/m)", "Fig. 3.10"))):
        a.set_xlabel(xl)
        a.set_ylabel("optimal Bm [N s/m]")
        a.set_title(title, fontsize=9)
        a.legend(fontsize=7)
    fig.suptitle(f"dynamic impedance selection (§3.3.1): Bm minimising E = W||x~||^2 + ||f~||^2, "
                 f"Km = W/Ke, W = {W_DUALITY:g}, f3dB = 20 Hz unless varied", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def demonstration_from_recording(path: str, dig: int, out: str | Path, *,
                                 say: Callable[[str], None] = print) -> Path:
    """``excavsim playback --from-rrd``: dig number ``dig`` (1-based) of a Rerun recording as a
    demonstration, written to ``out/rrd_demonstration.json``; returns that path."""
    from excavsim.record.demo_reading import read_dig

    recorded = read_dig(path, dig)
    demo = demonstration_from_signals(recorded.joint_times, recorded.joints, recorded.ft_times, recorded.ft_tip,
                                      recorded.path_world, source=f"{path}, dig {recorded.dig}")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    saved = demo.save(out / "rrd_demonstration.json")
    say(f"wrote {saved}: dig {recorded.dig} of {path} ({len(demo.times)} samples, {demo.times[-1]:.2f} s); "
        f"play it back with: excavsim playback --demo {saved}")
    return saved


def run_chapter6(out: str | Path, *, seed: int = 0, seeds: list[int] | None = None, sweep: bool = True,
                 demo_path: str | None = None, say: Callable[[str], None] = print) -> None:
    """``excavsim playback``: the chapter-6 experiment (:func:`run_playback`), or over ``seeds``
    (:func:`run_seeds`), with the demonstration of ``demo_path`` instead of a recorded one when given."""
    from excavsim.execution.demonstration import load_demonstration

    say("excavsim playback: demonstrate a dig, replay it in a stiffer and a softer soil with fixed high, moderate, "
        "low and variable impedance (DiMaio 1998 §3.3, ch. 6)")
    demo = load_demonstration(demo_path) if demo_path else None
    out = Path(out)
    if seeds is not None:
        say(f"over seeds {', '.join(map(str, seeds))}: each seed records its own demonstration"
            + (" (here: the given one)" if demo is not None else "") + " and replays it in worlds of that seed")
        run_seeds(seeds, out, sweep=sweep, demo=demo)
        return
    run_playback(out, seed=seed, sweep=sweep, demo=demo)
