"""The chapter-6 experiment's figures (DiMaio 1998 Figs. 6.42-6.48, Figs. 3.7-3.10), written by
:func:`excavsim.apps.playback.driver.run_playback` where the machine's report has them (the T3's)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from excavsim.apps.playback.adapter import W, Impedance
from excavsim.execution.playback import PlaybackRun


def _slug(text: str) -> str:
    return "".join(c if c.isalnum() else "_" for c in text).strip("_")


def plot_runs(runs: dict[tuple[str, str], PlaybackRun], out: Path) -> None:
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


def plot_errors(table: dict, path: Path) -> None:
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


def plot_sweep(table: dict, soils: list[str], impedance: Impedance, path: Path) -> None:
    """The velocity-weighting sweep of Figs. 6.46-6.48: the variable controller's errors against G, with the
    fixed impedances' as horizontal lines (the controllers of ``impedance``)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    imp = impedance
    gs = sorted([*(g for _, g in imp.g_sweep), imp.g_n_s_m])
    names = {g: imp.variable if g == imp.g_n_s_m else imp.sweep_name(g) for g in gs}
    fig, ax = plt.subplots(3, len(soils), figsize=(5 * len(soils), 8), squeeze=False, sharex=True)
    for c, soil in enumerate(soils):
        for r, (key, scale, lab) in enumerate((("pos_rms_m", 100.0, "position RMS [cm]"),
                                               ("force_rms_n", 1.0, "force RMS error [N]"),
                                               ("weighted_error", 1e-3, "E [1e3]"))):
            a = ax[r, c]
            a.semilogx(gs, [scale * table[soil, names[g]][key] for g in gs], "o-", color="C3",
                       label="variable + depth")
            for j, (fixed, _) in enumerate(imp.fixed):
                a.axhline(scale * table[soil, fixed][key], color=f"C{j}", ls="--", label=fixed)
            a.set_ylabel(lab)
        ax[0, c].set_title(soil)
        ax[-1, c].set_xlabel("velocity weighting G [N s/m] (eq. 3.37)")
    ax[0, 0].legend(fontsize=7)
    fig.suptitle(f"velocity-weighting sweep (Figs. 6.46-6.48: G = 100, 1000, 1e5; the chapter's G = {imp.g_n_s_m:g})")
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
