"""The scanner's figures (Singh 1995 §7.1.2, Figs. 96-99, 102) and the map-error table of the testbed.

:func:`map_error_table` measures, over seeds, what the elevation map's pipelines make of the
testbed's scanner (``configs/sensing_testbed.yaml``: beam footprint and mixed pixels, incidence and
reflectance bias, the mount's pose error, the temperature drift): the thesis' pipeline (target
calibration with the scanner's pose, median of ten scans, Fig. 96's edge filter, 5 cm cells, no
levelling), the same with the range calibration alone and without the edge filter (the narrowest
reading of §7.1.2), and with the mind's wall-top levelling on top. Each map is compared with the
true terrain (privileged). ``excavsim figures fig97`` prints it; the numbers are in
docs/notes/2026-12-02-scanner-errors.md.
"""

from __future__ import annotations

import dataclasses
import pathlib

import numpy as np

from excavsim import constants
from excavsim.config import SensingConfig, load_sensing_config
from excavsim.planning.figures import _figure, _save
from excavsim.sensing.elevation import (build_map, calibrate, edge_pixels, map_accuracy, median_ranges,
                                        true_cell_heights)
from excavsim.world.scanner import LaserScanner
from excavsim.world.simulation import Simulation

TESTBED_YAML = constants.CONFIGS_DIR / "sensing_testbed.yaml"
TRENCH_DEPTH_M = 0.3  # the steep-walled trench of the "trenched" terrain

# name -> the map settings over the testbed config's (which has the pose calibration, the edge filter
# and levelling on)
PIPELINES: dict[str, dict] = {
    "range calibration only, no edge filter, no levelling": dict(calibrate_pose=False, edge_filter_m=0.0,
                                                                 level=False),
    "thesis: pose + range calibration, edge filter, no levelling": dict(level=False),
    "thesis + wall-top levelling": dict(level=True),
    "range calibration only + levelling (no edge filter)": dict(calibrate_pose=False, edge_filter_m=0.0,
                                                                level=True),
}
THESIS = "thesis: pose + range calibration, edge filter, no levelling"


def trench_terrain(sim: Simulation) -> np.ndarray:
    """The box's terrain with a steep-walled trench 0.3 m deep across it (0.5 m wide, 2 m long)."""
    g = sim.soil.grid
    h = g.heights.copy()
    ny, nx = g.shape
    rows = slice(ny // 2 - 10, ny // 2 + 10)
    cols = slice(nx // 2 - 40, nx // 2 + 40)
    h[rows, cols] -= TRENCH_DEPTH_M
    return h


@dataclasses.dataclass(frozen=True)
class MapErrors:
    """RMS map errors [m] per pipeline and seed, on one terrain."""

    terrain: str
    seeds: tuple[int, ...]
    rms_m: dict[str, np.ndarray]
    bias_m: dict[str, np.ndarray]

    def pooled_m(self, name: str) -> float:
        """The RMS over all seeds' cells (the root of the mean of the squared per-seed RMS)."""
        return float(np.sqrt(np.mean(self.rms_m[name] ** 2)))

    def lines(self) -> list[str]:
        out = [f"{self.terrain}, seeds {self.seeds[0]}-{self.seeds[-1]}: pooled RMS [per-seed min-max] cm"]
        for name, r in self.rms_m.items():
            out.append(f"  {name}: {100 * self.pooled_m(name):.2f} [{100 * r.min():.2f}-{100 * r.max():.2f}]")
        return out


def map_error_table(seeds=range(8), *, terrain: str = "flat", sensing: SensingConfig | None = None,
                    pipelines: dict[str, dict] | None = None) -> MapErrors:
    """Ten scans per seed by the testbed's scanner, mapped by each pipeline, against the truth.

    Args:
        seeds: world and scanner seeds (the scanner's generator is ``(seed, 7)``, as the loop's).
        terrain: ``flat`` (the box as built) or ``trenched`` (:func:`trench_terrain`: a steep-walled trench dug).
        sensing: the scanner and map settings (default ``configs/sensing_testbed.yaml``).
    """
    if terrain not in ("flat", "trenched"):
        raise ValueError(f"terrain {terrain!r}; allowed: flat, trenched")
    cfg = sensing or load_sensing_config(TESTBED_YAML)
    pipelines = pipelines or PIPELINES
    rms = {k: [] for k in pipelines}
    bias = {k: [] for k in pipelines}
    seeds = tuple(seeds)
    for seed in seeds:
        sim = Simulation(seed=seed)
        if terrain == "trenched":
            sim.soil.grid.heights[:] = trench_terrain(sim)
        sc = LaserScanner(sim.model, sim.soil.grid, cfg.scanner, np.random.default_rng((seed, 7)))
        images = [sc.scan(0.1 * k) for k in range(cfg.map.n_scans)]
        for name, update in pipelines.items():
            emap, cals = build_map(images, sc.geometry, cfg.map.model_copy(update=update))
            acc = map_accuracy(emap, sim.soil.grid.surface_z, cals)
            rms[name].append(acc.rms_m)
            bias[name].append(acc.mean_m)
    return MapErrors(terrain, seeds, {k: np.array(v) for k, v in rms.items()},
                     {k: np.array(v) for k, v in bias.items()})


def _testbed_scans(seed: int, terrain: str = "trenched"):
    cfg = load_sensing_config(TESTBED_YAML)
    sim = Simulation(seed=seed)
    if terrain == "trenched":
        sim.soil.grid.heights[:] = trench_terrain(sim)
    sc = LaserScanner(sim.model, sim.soil.grid, cfg.scanner, np.random.default_rng((seed, 7)))
    return cfg, sim, sc, [sc.scan(0.1 * k) for k in range(cfg.map.n_scans)]


def fig96(ctx, path: pathlib.Path) -> str:
    """Fig. 96: range image, reflectance image, edges, filtered pixels (testbed scanner, a trench)."""
    cfg, sim, sc, images = _testbed_scans(ctx.seed)
    cals = [calibrate(im, sc.geometry) for im in images]
    r = median_ranges(images, cals)
    edges = edge_pixels(r, cfg.map.edge_filter_m)
    filtered = edges | ~np.isfinite(r)
    fig = _figure((10.0, 8.0))
    panels = [("range image [m]", r, "viridis"), ("reflectance image", images[0].reflectance, "gray"),
              (f"edges (range jumps > {100 * cfg.map.edge_filter_m:.0f} cm)", edges.astype(float), "gray_r"),
              ("filtered pixels (dark): edges and no return", filtered.astype(float), "gray_r")]
    for i, (title, img, cmap) in enumerate(panels):
        ax = fig.add_subplot(2, 2, i + 1)
        im = ax.imshow(img, cmap=cmap, aspect="auto")
        if i < 2:
            fig.colorbar(im, ax=ax, fraction=0.04)
        ax.set_title(title, fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])
    fig.suptitle("Fig. 96: processing of the testbed scanner's images (seed %d, a 0.3 m trench)" % ctx.seed, fontsize=10)
    _save(fig, path)
    refl = images[0].reflectance
    return (f"{int(np.isfinite(r).sum())} pixels with a return, {int(edges.sum())} at edges filtered; reflectance "
            f"median {np.nanmedian(refl):.2f} (soil 0.3 x texture, walls 0.5, targets 0.1, x cos (3 m / r)^2)")


def fig97(ctx, path: pathlib.Path) -> str:
    """Fig. 97: an elevation map from the testbed's scanner, its error, and the 8-seed error table."""
    cfg, sim, sc, images = _testbed_scans(ctx.seed)
    thesis = cfg.map.model_copy(update=PIPELINES[THESIS])
    emap, cals = build_map(images, sc.geometry, thesis)
    truth = true_cell_heights(emap, sim.soil.grid.surface_z)
    err = np.where(emap.observed, emap.heights - truth, np.nan)
    fig = _figure((11.0, 4.6))
    x0, x1, y0, y1 = emap.extent
    ax = fig.add_subplot(1, 2, 1)
    im = ax.imshow(emap.heights, origin="lower", extent=(x0, x1, y0, y1), cmap="terrain")
    fig.colorbar(im, ax=ax, label="z [m]")
    ax.set_title("elevation map (thesis pipeline, 5 cm cells)", fontsize=9)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax = fig.add_subplot(1, 2, 2)
    lim = float(np.nanpercentile(np.abs(err), 99)) if np.isfinite(err).any() else 0.05
    im = ax.imshow(100 * err, origin="lower", extent=(x0, x1, y0, y1), cmap="RdBu_r", vmin=-100 * lim, vmax=100 * lim)
    fig.colorbar(im, ax=ax, label="map - truth [cm] (blank: unobserved)")
    ax.set_title("its error against the true terrain", fontsize=9)
    ax.set_xlabel("x [m]")
    fig.suptitle(f"Fig. 97: terrain map from the testbed scanner (seed {ctx.seed}, a 0.3 m trench)", fontsize=10)
    _save(fig, path)
    acc = map_accuracy(emap, sim.soil.grid.surface_z, cals)
    table = map_error_table(range(8), terrain="flat")
    return f"this map: {acc.summary()}\n    " + "\n    ".join(table.lines())


def fig98(ctx, path: pathlib.Path) -> str:
    """Fig. 98: range to four targets over a hundred scans: Gaussian noise about a slow drift."""
    cfg = load_sensing_config(TESTBED_YAML)
    sim = Simulation(seed=ctx.seed)
    sc = LaserScanner(sim.model, sim.soil.grid, cfg.scanner, np.random.default_rng((ctx.seed, 7)))
    n = 100
    rows = np.array([np.nanmedian(sc.scan(float(k)).target_ranges, axis=1) for k in range(n)])
    surveyed = sc.geometry.target_ranges.mean(axis=1)
    fig = _figure((8.0, 4.2))
    ax = fig.add_subplot()
    for i in (0, 2, 4, 6):
        ax.plot(np.arange(n), 100 * (rows[:, i] - surveyed[i]), lw=1.0, label=f"target {i} ({surveyed[i]:.2f} m)")
    ax.set_xlabel("scan")
    ax.set_ylabel("measured - surveyed range [cm]")
    ax.set_title("Fig. 98: ranges to four targets over time: noise about a slow (temperature-like) drift",
                 fontsize=9)
    ax.legend(fontsize=7)
    _save(fig, path)
    dev = rows[:, [0, 2, 4, 6]] - surveyed[[0, 2, 4, 6]]
    return (f"deviation over {n} scans: std {100 * np.nanstd(dev):.2f} cm, scan-to-scan std "
            f"{100 * np.nanstd(np.diff(dev, axis=0)) / np.sqrt(2):.2f} cm")


def fig99(ctx, path: pathlib.Path) -> str:
    """Fig. 99: a 10 % range scale error on a terrain profile, and the contact-adjusted profile."""
    sim = Simulation(seed=ctx.seed)
    h = trench_terrain(sim)
    g = sim.soil.grid
    cfg = load_sensing_config(TESTBED_YAML).scanner
    origin = LaserScanner(sim.model, g, cfg, np.random.default_rng(0)).geometry.origin
    col = g.shape[1] // 2
    y = g.y0 + np.arange(g.shape[0]) * g.cell
    z = g.z0 + h[:, col]
    x = g.x0 + col * g.cell
    pts = np.column_stack([np.full_like(y, x), y, z])
    b = origin + 0.9 * (pts - origin)  # each range 90 % of the truth
    touch = int(np.argmin(np.abs(y - 0.0)))  # contact found at x' near y = 0 (the trench's floor)
    c = b[:, 2] + (z[touch] - b[touch, 2])
    fig = _figure((8.0, 4.0))
    ax = fig.add_subplot()
    ax.plot(y, z, "k-", label="A: true profile")
    ax.plot(b[:, 1], b[:, 2], "C3--", label="B: ranges 90 % of true")
    ax.plot(b[:, 1], c, "C0:", label="C: B shifted to the contact at x'")
    ax.plot([y[touch]], [z[touch]], "ko")
    ax.set_xlabel("y [m]")
    ax.set_ylabel("z [m]")
    ax.set_title("Fig. 99: a scale error in range on the terrain map, and the contact adjustment", fontsize=9)
    ax.legend(fontsize=7)
    _save(fig, path)
    return (f"B lies {100 * float(np.mean(b[:, 2] - z)):+.1f} cm from A on average; C matches at x' and is off by "
            f"{100 * float(np.max(np.abs(np.interp(y, b[:, 1], c) - z))):.1f} cm at worst elsewhere")


def fig102(ctx, path: pathlib.Path) -> str:
    """Fig. 102: the least-squares fit of measured against surveyed ranges at the targets."""
    cfg = load_sensing_config(TESTBED_YAML)
    sim = Simulation(seed=ctx.seed)
    sc = LaserScanner(sim.model, sim.soil.grid, cfg.scanner, np.random.default_rng((ctx.seed, 7)))
    for _ in range(20):  # let the drift build up
        sc.drift()
    im = sc.scan(0.0)
    cal = calibrate(im, sc.geometry)
    s, m = sc.geometry.target_ranges.ravel(), im.target_ranges.ravel()
    fig = _figure((6.0, 5.0))
    ax = fig.add_subplot()
    ax.plot(s, m, "o", ms=3, label="target rays")
    xs = np.linspace(s.min(), s.max(), 2)
    ax.plot(xs, cal.scale * xs + cal.offset, "k-", label=f"fit: scale {cal.scale:.4f}, offset {100 * cal.offset:+.2f} cm")
    ax.plot(xs, xs, "k:", lw=0.8, label="scale 1, offset 0")
    ax.set_xlabel("surveyed range [m]")
    ax.set_ylabel("measured range [m]")
    ax.set_title("Fig. 102: range calibration against the surveyed targets", fontsize=9)
    ax.legend(fontsize=7)
    _save(fig, path)
    return (f"scale {cal.scale:.4f} (true {1 + sc.scale_error:.4f}), offset {100 * cal.offset:+.2f} cm; "
            f"{cal.n_used} rays used, residual RMS {100 * cal.rms_residual_m:.2f} cm")
