"""The Fig. 12-style learning curve of the truck loading (Rowe 1997 §6.2, Fig. 12) from a campaign's episodes.

Rowe's Fig. 12 plots, trial after trial, the cost, the time and the squared placement error of the dump
while the learner tunes the script. Here a trial is a pass of a truck (task ``truck_loading``): the curve
is the mean over a campaign's seeds, per pass, of the pass's cost (§6.2), its cycle time and its squared
placement error, one line per soil and per tuned/untuned; the first passes of every run are the computed
parameters plus noise (the dashed line marks where the learner takes over).

``excavsim truck-curve DIR`` draws it from the episodes of ``excavsim campaign`` (``DIR/episodes/*.json``,
e.g. of ``configs/campaigns/excavator_truck.yaml``).
"""

from __future__ import annotations

import json
import pathlib
from collections import defaultdict

import numpy as np

from excavsim.errors import ConfigError


def read_runs(campaign_dir: str | pathlib.Path) -> dict[tuple[str, bool], list[list[dict]]]:
    """Per (soil, tuned) the runs' per-pass rows, from ``DIR/episodes/*.json`` of task truck_loading.

    Raises:
        ConfigError: the directory holds no truck_loading episode that ended well.
    """
    runs: dict[tuple[str, bool], list[list[dict]]] = defaultdict(list)
    for path in sorted(pathlib.Path(campaign_dir, "episodes").glob("*.json")):
        rec = json.loads(path.read_text())
        s = rec.get("summary") or {}
        if rec.get("status") != "ok" or s.get("task") != "truck_loading":
            continue
        runs[(s["soil"], bool(s["tuned"]))].append(rec["digs"])
    if not runs:
        raise ConfigError(f"{campaign_dir}: no truck_loading episode in episodes/*.json (run excavsim campaign on "
                          "configs/campaigns/excavator_truck.yaml first)")
    return dict(runs)


def learning_curve(campaign_dir: str | pathlib.Path, out: str | pathlib.Path, *, initial_passes: int = 3) -> str:
    """Draw the curve (module docstring) into ``out`` (PNG); returns a line per (soil, tuned): the mean cost
    and time of the first ``initial_passes`` passes and of the passes after them."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    runs = read_runs(campaign_dir)
    fig, ax = plt.subplots(3, 1, figsize=(7, 8), sharex=True)
    lines = []
    for (soil, tuned), rs in sorted(runs.items()):
        n = max(len(r) for r in rs)
        per = {k: [[row[k] for row in r[:n]] for r in rs] for k in ("cost", "cycle_s", "placement_error_cm")}
        mean = {}
        for k, v in per.items():
            m = np.full(n, np.nan)
            for i in range(n):
                vals = [x[i] for x in v if i < len(x)]
                m[i] = float(np.mean(vals)) if vals else np.nan
            mean[k] = m
        err2 = (mean["placement_error_cm"] / 100.0) ** 2
        style = "-" if tuned else ":"
        label = f"{soil} {'tuned' if tuned else 'untuned'}"
        x = np.arange(1, n + 1)
        ax[0].plot(x, mean["cost"], style, marker="o", ms=3, label=label)
        ax[1].plot(x, mean["cycle_s"], style, marker="o", ms=3)
        ax[2].plot(x, err2, style, marker="o", ms=3)
        k = initial_passes
        lines.append(f"{label}: {len(rs)} runs; passes 1-{k}: cost {np.nanmean(mean['cost'][:k]):.1f}, "
                     f"{np.nanmean(mean['cycle_s'][:k]):.1f} s; passes {k + 1}-{n}: cost "
                     f"{np.nanmean(mean['cost'][k:]):.1f}, {np.nanmean(mean['cycle_s'][k:]):.1f} s")
    for a, label in zip(ax, ("cost (§6.2)", "cycle time [s]", "squared placement error [m^2]")):
        a.axvline(initial_passes + 0.5, color="grey", lw=0.8, ls="--")
        a.set_ylabel(label)
    ax[0].legend(fontsize=7, ncol=2)
    ax[0].set_title("Truck loading by the 25 t excavator, per pass (cf. Rowe 1997 Fig. 12); mean over seeds",
                    fontsize=9)
    ax[-1].set_xlabel("pass (trial)")
    fig.tight_layout()
    out = pathlib.Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return "\n".join(lines)
