"""Fig. 100 (Singh 1995 §7.1.2): a range scale error's effect on a dig's trajectory and swept volume.

The scanner's ranges are read ``SCALE`` of their true length (a scale error the per-scan target
calibration of Fig. 102 would remove, left uncorrected here). On the testbed's scanner geometry
(``configs/sensing_testbed.yaml``: the scanner 3 m up beside the box) every point of the map then
moves towards the scanner: the map B lies above the true terrain A by ``(1 - SCALE)`` of the
scanner's height above each point, and its features shift sideways towards the scanner. Fig. 99's
contact adjustment shifts B so that it meets A where touch-down found contact (x', on the trench's
floor as in Fig. 99), which leaves it too low where the terrain is higher. A dig (a trenching action of
§3.4.1: enter, penetrate ``D1_M`` at ``ALPHA_RAD``, drag ``D2_M``, curl up) is planned on a map and
executed as planned, open loop (§7.1.2: "digging trajectories are executed open loop"):

* (a) planned on B: the swept area the planner expects (between B and the path);
* (b) executed on A without adjusting for the error: the path lies as far above A as B does, and the
  bucket does not engage the terrain fully;
* (c) planned on the contact-adjusted map C, executed on A: the path lies below where C put it, so
  the bucket engages too aggressively.

Geometry only (the swept area of the tip path below the surface, times the bucket's width), in
Fig. 99's cross-section of the box (the profile across the trench, through the scanner), with the
terrain taken as uniform along the trench. Privileged truth, for the figure.
"""

from __future__ import annotations

import dataclasses
import math
import pathlib

import numpy as np

from excavsim.config import load_sensing_config
from excavsim.planning.figures import _figure, _save
from excavsim.studies.figures.sensing import TESTBED_YAML, trench_terrain
from excavsim.world.scanner import LaserScanner
from excavsim.world.simulation import Simulation

SCALE = 0.95  # each range 95 % of the true one (Fig. 99 draws 10 %; 5 % keeps the dig in the soil)
ENTRY_Y_M = 0.95  # the dig enters the top beside the trench and drags towards it [m]
D1_M, ALPHA_RAD, D2_M = 0.20, math.radians(40.0), 0.25  # penetration, approach angle, drag (§3.4.1)
WIDTH_M = 0.3  # the bucket's width: swept area x width = swept volume [m]
LABELS = {"a": "(a) planned on B", "b": "(b) B's plan executed on A", "c": "(c) C's plan executed on A",
          "c_planned": "(c) as planned on C"}


@dataclasses.dataclass(frozen=True)
class ScaleDig:
    """The profiles and the three digs of Fig. 100 (heights [m] on ``y`` [m]).

    Attributes:
        y: the cross-section's sample positions.
        true, mapped, adjusted: A, B and C on ``y``.
        contact_y: x', where touch-down met A.
        planned_b, planned_c: (n, 2) tip paths (y, z) planned on B and on C.
        volumes: swept volume [m^3] by panel (``LABELS``): "a" the plan on B as the planner sees it,
            "b" that plan on A, "c" the plan on C executed on A, "c_planned" the plan on C as the planner sees it.
    """

    y: np.ndarray
    true: np.ndarray
    mapped: np.ndarray
    adjusted: np.ndarray
    contact_y: float
    planned_b: np.ndarray
    planned_c: np.ndarray
    volumes: dict[str, float]


def dig_path(surface_y: np.ndarray, surface_z: np.ndarray, entry_y: float = ENTRY_Y_M) -> np.ndarray:
    """The tip path (n, 2) of the trenching action planned on a surface: enter at ``entry_y`` on it,
    penetrate ``D1_M`` at ``ALPHA_RAD`` below horizontal towards -y, drag ``D2_M`` level, curl up to it."""
    z0 = float(np.interp(entry_y, surface_y, surface_z))
    p1 = (entry_y - D1_M * math.cos(ALPHA_RAD), z0 - D1_M * math.sin(ALPHA_RAD))
    p2 = (p1[0] - D2_M, p1[1])
    top = float(np.interp(p2[0], surface_y, surface_z))
    return np.array([(entry_y, z0), p1, p2, (p2[0], max(top, p2[1]))])


def swept_volume(path: np.ndarray, surface_y: np.ndarray, surface_z: np.ndarray, n: int = 2000) -> float:
    """The area between a surface and the tip path where the path runs below it, times the bucket's width [m^3]."""
    y = np.linspace(path[:, 0].min(), path[:, 0].max(), n)
    z_path = np.interp(y, path[::-1, 0], path[::-1, 1])  # the path's y falls from the entry; its curl is vertical
    depth = np.clip(np.interp(y, surface_y, surface_z) - z_path, 0.0, None)
    return float(np.sum((depth[1:] + depth[:-1]) / 2 * np.diff(y))) * WIDTH_M


def scale_dig(seed: int = 0, scale: float = SCALE) -> ScaleDig:
    """Fig. 100's profiles, plans and swept volumes for a range scale error ``scale`` (see the module docstring)."""
    sim = Simulation(seed=seed)
    g = sim.soil.grid
    h = trench_terrain(sim)
    origin = LaserScanner(sim.model, g, load_sensing_config(TESTBED_YAML).scanner,
                          np.random.default_rng(0)).geometry.origin
    col = g.shape[1] // 2
    y = g.y0 + np.arange(g.shape[0]) * g.cell
    z = g.z0 + h[:, col]
    b_y = origin[1] + scale * (y - origin[1])  # each range `scale` of the true: the points move towards the scanner
    b_z = origin[2] + scale * (z - origin[2])
    mapped = np.interp(y, b_y, b_z)
    contact = int(np.argmin(np.abs(y)))  # touch-down on the trench's floor, as Fig. 99's x'
    adjusted = mapped + (z[contact] - mapped[contact])
    pb, pc = dig_path(y, mapped), dig_path(y, adjusted)
    vols = {"a": swept_volume(pb, y, mapped), "b": swept_volume(pb, y, z), "c": swept_volume(pc, y, z),
            "c_planned": swept_volume(pc, y, adjusted)}
    return ScaleDig(y, z, mapped, adjusted, float(y[contact]), pb, pc, vols)


def _panel(ax, y, surface, path, label: str, title: str) -> None:
    sel = (y >= path[:, 0].min() - 0.3) & (y <= path[:, 0].max() + 0.3)
    yy = np.linspace(path[:, 0].min(), path[:, 0].max(), 400)
    zs = np.interp(yy, y, surface)
    zp = np.interp(yy, path[::-1, 0], path[::-1, 1])
    ax.fill_between(yy, np.minimum(zp, zs), zs, color="0.3", label="swept")
    ax.plot(y[sel], surface[sel], "k-", lw=1, label=label)
    ax.plot(path[:, 0], path[:, 1], "C3-", lw=1.2, label="tip path")
    ax.set_title(title, fontsize=8)
    ax.set_xlabel("y [m]")


def fig100(ctx, path: pathlib.Path) -> str:
    """Fig. 100: a dig planned on a map with a range scale error, executed as planned on the true
    terrain (b) and planned on the contact-adjusted map (c); swept areas dark, volumes printed."""
    d = scale_dig(ctx.seed)
    v = d.volumes
    fig = _figure((11.0, 3.8))
    axes = [fig.add_subplot(1, 3, k + 1) for k in range(3)]
    _panel(axes[0], d.y, d.mapped, d.planned_b, "B: the map (ranges %.0f %%)" % (100 * SCALE),
           f"(a) planned on B: {1000 * v['a']:.1f} l")
    _panel(axes[1], d.y, d.true, d.planned_b, "A: the terrain",
           f"(b) executed without adjusting: {1000 * v['b']:.1f} l")
    _panel(axes[2], d.y, d.true, d.planned_c, "A: the terrain",
           f"(c) planned on C (adjusted at x'), executed: {1000 * v['c']:.1f} l (planned {1000 * v['c_planned']:.1f} l)")
    axes[1].plot(d.y, d.mapped, "C1--", lw=0.8, label="B: the map")
    axes[2].plot(d.y, d.adjusted, "C0:", lw=1, label="C: B shifted to meet A at x'")
    lo, hi = d.planned_b[:, 0].min() - 0.25, d.planned_b[:, 0].max() + 0.25
    for ax in axes:
        ax.set_xlim(lo, hi)
        ax.set_ylim(0.3, 0.7)
        ax.legend(fontsize=6, loc="lower left")
    axes[0].set_ylabel("z [m]")
    fig.suptitle("Fig. 100: a range scale error, the digging trajectory and the swept volume (dark)", fontsize=10)
    _save(fig, path)
    return "; ".join(f"{LABELS[k]}: {1000 * val:.1f} l" for k, val in v.items())
