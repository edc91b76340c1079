"""Figures of force learning: Fig. 81 of Singh 1995, errors on large forces.

matplotlib's object-oriented API on an Agg canvas (no pyplot, no display), as
:mod:`excavsim.planning.figures`.
"""

from __future__ import annotations

import pathlib
from collections.abc import Sequence

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from excavsim.learning.dataset import ForceDataset
from excavsim.learning.evaluate import LARGE_FORCE_N, CVResult, large_force_errors

# Fig. 81's panels: (a) wedge model, (b) global regression, (c) locally weighted regression, (d) neural net
FIG81_METHODS = ("wedge_fit", "global", "lwr_scaled", "net")


def plot_large_force_errors(path: str | pathlib.Path, results: Sequence[CVResult], data: ForceDataset, *,
                            basis: str = "mechanics", threshold: float = LARGE_FORCE_N,
                            methods: Sequence[str] = FIG81_METHODS, title: str = "") -> pathlib.Path:
    """Histograms of ``|F|_predicted - |F|_observed`` over the samples whose observed |F_x| or |F_z|
    exceeds ``threshold`` [N] (Fig. 81), one panel per method (on ``basis`` where it has one).

    Returns:
        The PNG written.
    """
    chosen = [r for m in methods for r in results if r.method == m and r.basis in (None, basis)]
    errors = large_force_errors(chosen, data, threshold=threshold)
    n = max(len(errors), 1)
    fig = Figure(figsize=(3.2 * n, 3.4), layout="constrained")
    FigureCanvasAgg(fig)
    allerr = np.concatenate(list(errors.values())) if errors else np.zeros(1)
    lim = float(np.percentile(np.abs(allerr), 99)) if allerr.size else 1.0
    bins = np.linspace(-lim, lim, 41)
    axes = fig.subplots(1, n, sharey=True, squeeze=False)[0]
    for ax, (letter, (label, err)) in zip(axes, zip("abcdefgh", errors.items())):
        ax.hist(np.clip(err, -lim, lim), bins=bins, color="#4c72b0")
        ax.axvline(0.0, color="k", lw=0.8)
        ax.set_title(f"({letter}) {label}", fontsize=8)
        ax.set_xlabel("predicted - observed |F| [N]")
        ax.text(0.02, 0.97, f"n {err.size}\nmean {err.mean():+.0f} N\nMAE {np.abs(err).mean():.0f} N",
                transform=ax.transAxes, va="top", fontsize=7)
    axes[0].set_ylabel("samples")
    fig.suptitle(title or f"Errors on forces above {threshold:.0f} N in F_x or F_z (negative: underestimated)",
                 fontsize=9)
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    return path
