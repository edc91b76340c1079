"""The chapter-6 experiment (002_694c274da322d931.txt §6.1-6.3, Figs. 6.42-6.48): demonstrate a dig
in one soil, play it back in a stiffer and a softer one with each impedance controller.

The demonstration is the cut of :data:`~excavsim.loop.demo.DEMO_ACTION` recorded by the dig executor
in the demonstration soil (world model ``dimaio``); a 10 cm free-motion descent onto the entry is
prepended (:meth:`~excavsim.execution.playback.Demonstration.with_approach`) so that the variable
impedance shows its switch from the air to the soil. Each playback runs in a fresh world with the
same seed: the arm goes home, to the approach pose, and then
:class:`~excavsim.execution.playback.ImpedancePlayback` runs at the control rate.

The playback soils are Table 6.4's kind of change of the demonstration soil's DiMaio parameters
(assumed factors, :data:`STIFFER` and :data:`SOFTER`): every viscous, stiffness, shear and
accumulation term scaled up (down). The controllers use Table 6.5's mass (100 kg), stiffness range
(1e3 - 1e5 N/m) and damping factor (1.0); the velocity weighting G of eq. 3.37 is swept as in
Figs. 6.46-6.48 (low, high, medium).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np

from excavsim.config import SoilParams, get_soil, load_scene_config
from excavsim.execution.playback import (Demonstration, FixedImpedance, ImpedancePlayback, PlaybackRun,
                                         VariableImpedance, demonstration_from_record)
from excavsim.handoff.dig import DigPlan
from excavsim.handoff.maps import ElevationMap
from excavsim.loop.demo import DEMO_ACTION
from excavsim.loop.rig import go_home, go_to, make_rig
from excavsim.world.simulation import Simulation

DEMO_SOIL = "testbed_sand"
# Table 6.4's kind of change (assumed factors): the playback soil is harder (softer) in every term
SCALED = ("viscous_tangential_n_s_m2", "viscous_normal_n_s_m2", "viscous_angular_n_s", "stiffness_n_m",
          "angular_stiffness_nm_rad", "shear_strength_pa", "accumulation_n_m3")
STIFFER, SOFTER = 3.0, 0.3
MASS, K_MIN, K_MAX = 100.0, 1.0e3, 1.0e5  # Table 6.5
W = 1.0e6  # §3.3.1: 1 mm of position error weighs as 1 N of force error (for the printed E)
G_SWEEP = {"low G": 100.0, "high G": 100000.0, "medium G": 1000.0}  # Figs. 6.46, 6.47, 6.48


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
    laws = [FixedImpedance("position (high K)", MASS, K_MAX), FixedImpedance("force (low K)", MASS, K_MIN),
            VariableImpedance("variable (G=1000)", MASS, K_MIN, K_MAX, G_SWEEP["medium G"])]
    if sweep:
        laws += [VariableImpedance(f"variable ({k}={g:g})", MASS, K_MIN, K_MAX, g)
                 for k, g in G_SWEEP.items() if k != "medium G"]
    return laws


def record_demonstration(seed: int = 0, soil: str = DEMO_SOIL) -> Demonstration:
    """Dig :data:`DEMO_ACTION` with the executor in ``soil`` and take its cut as the demonstration."""
    sim = make_world(get_soil(soil), seed)
    rig = make_rig(sim, seed=seed)
    go_home(sim, rig)
    z = float(np.median(sim.soil.grid.heights))  # the flat fill (privileged, only to lay out the demo dig)
    emap = ElevationMap(0.55, -1.5, 0.05, np.full((60, 60), z), np.ones((60, 60), bool), 0.0)
    surface = rig.planner.surface(emap)
    poses, phases = rig.planner.trajectory(DEMO_ACTION, surface)
    waist = math.radians(rig.goal.waist_deg)
    plan = DigPlan(poses, phases, waist, rig.planner.swept_volume(poses, surface))
    rec = rig.executor.run(plan)
    return demonstration_from_record(rec, arm=rig.arm, ft=rig.executor.ft, waist=waist, dt=sim.control_dt,
                                     source=f"executor record of {DEMO_ACTION} ({rec.outcome})", soil=soil)


def play(demo: Demonstration, soil: SoilParams, label: str, law, seed: int = 0) -> PlaybackRun:
    """One playback of ``demo`` in a fresh world of ``soil`` with impedance ``law``."""
    sim = make_world(soil, seed)
    rig = make_rig(sim, seed=seed)
    go_home(sim, rig)
    q = rig.home.copy()
    q[0] = demo.waist
    q[1:4], ok = rig.arm.inverse(demo.pose[0])
    if not ok:
        raise RuntimeError("playback: the demonstration's first pose is out of reach")
    go_to(sim, q, rig.executor_cfg)
    return ImpedancePlayback(sim, rig.arm, rig.executor.ft, law).run(demo, soil=label)


def run_playback(out: Path | None = None, *, seed: int = 0, sweep: bool = True,
                 progress: Callable[[str], None] = print) -> dict:
    """The experiment (see the module docstring); returns ``{(soil, controller): errors}`` and writes
    the demonstration, the plots and the error table into ``out``."""
    demo = record_demonstration(seed)
    progress(f"demonstration: {len(demo.times)} samples ({demo.times[-1]:.2f} s) in {demo.soil}; "
             f"{demo.source}")
    demo = demo.with_approach(0.10, 1.0)
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        demo.save(out / "demonstration.json")
    soils = {"same": get_soil(DEMO_SOIL), f"stiffer x{STIFFER:g}": scaled_soil(DEMO_SOIL, STIFFER),
             f"softer x{SOFTER:g}": scaled_soil(DEMO_SOIL, SOFTER)}
    runs: dict[tuple[str, str], PlaybackRun] = {}
    table = {}
    for label, soil in soils.items():
        for law in controllers(sweep and label != "same"):
            run = play(demo, soil, label, law, seed)
            runs[label, law.name] = run
            e = table[label, law.name] = run.errors(W)
            progress(f"{label:12s} {law.name:24s} pos rms {100 * e['pos_rms_m']:6.2f} cm max "
                     f"{100 * e['pos_max_m']:6.2f} cm | force rms err {e['force_rms_n']:7.1f} N max "
                     f"{e['force_max_err_n']:7.1f} N, peak {e['force_peak_n']:7.1f} N (demo "
                     f"{e['demo_force_peak_n']:6.1f} N) | E {e['weighted_error']:9.0f} | {run.outcome}")
    if out is not None:
        _plot(runs, out)
        lines = ["soil,controller,pos_rms_m,pos_max_m,force_rms_n,force_max_err_n,force_peak_n,weighted_error"]
        lines += [f"{s},{c},{e['pos_rms_m']:.4f},{e['pos_max_m']:.4f},{e['force_rms_n']:.1f},"
                  f"{e['force_max_err_n']:.1f},{e['force_peak_n']:.1f},{e['weighted_error']:.0f}"
                  for (s, c), e in table.items()]
        (out / "errors.csv").write_text("\n".join(lines) + "\n")
        progress(f"wrote {out}/demonstration.json, errors.csv and the figures")
    return table


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
        slug = "".join(c if c.isalnum() else "_" for c in f"{soil}_{name}").strip("_")
        fig.savefig(out / f"playback_{slug}.png", dpi=80)
        plt.close(fig)
