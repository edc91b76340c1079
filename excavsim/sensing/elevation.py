"""From range images to the elevation map the planner consumes (Singh 1995 §7.1.2).

The processing is the thesis' (Figs. 101-102 and the text around them):

1. **Calibration** of every range image (optionally with the mount's pose, ``calibrate_pose``:
   :func:`calibrate_pose`): a linear least-squares fit ``measured = scale * surveyed + offset`` over
   the rays aimed at the surveyed targets on the walls, with one pass of outlier rejection (a target
   hidden by a pile or a wild range), applied to the whole image as ``(r - offset) / scale``.
2. **Median filter** across N images (default 10), per pixel, ignoring dropouts.
3. **Levelling** (ours, not the thesis'): the points that fall on the surveyed tops of the box's
   walls fit a plane of the height error (:func:`wall_levelling`), subtracted from every point. The
   range calibration cannot see a misaligned mount, which tilts and lifts the map by a centimetre
   or two: enough to make a finished trench look 5 % short of its goal, or done when it is not.
   The **edge filter** (optional, ``edge_filter_m``; Fig. 96's filtered pixels) drops the pixels at
   range jumps (:func:`edge_pixels`), the mixed pixels a finite beam returns at edges.
4. **Binning**: pixels become world points along the known ray directions; points inside the soil
   area (less a 3 cm margin at the walls, whose faces would otherwise be read as soil) are reduced
   to their median height per cell of the map (default 5 cm).
5. **Unobserved cells** (occluded, grazing, off the field of view) are flagged and filled
   conservatively: repeatedly with the highest observed neighbour, i.e. assuming soil is there, so
   the planner never counts on empty space it has not seen.

The :class:`~excavsim.handoff.maps.ElevationMap` it builds is a value type of the hand-off package;
:func:`map_accuracy` compares it with the true terrain (privileged data, for tests and logging
only).
"""

from __future__ import annotations

import dataclasses
import time as _time
from collections.abc import Sequence
from typing import Protocol

import numpy as np

from excavsim.config import ElevationMapConfig
from excavsim.errors import UsageError, WorldError
from excavsim.handoff.maps import ElevationMap, RangeImage, ScanGeometry

WALL_MARGIN_M = 0.03


@dataclasses.dataclass(frozen=True)
class Calibration:
    """Scale and offset of one range image, and the residuals at the targets after correction [m].

    ``residuals`` has the shape of the target rays; rays without a return or rejected as outliers
    are NaN.
    """

    scale: float
    offset: float
    residuals: np.ndarray
    n_used: int

    @property
    def rms_residual_m(self) -> float:
        r = self.residuals[np.isfinite(self.residuals)]
        return float(np.sqrt(np.mean(r * r))) if r.size else float("nan")

    def correct(self, ranges: np.ndarray) -> np.ndarray:
        """Ranges corrected by this calibration."""
        return (ranges - self.offset) / self.scale


def calibrate(image: RangeImage, geometry: ScanGeometry, *, reject_m: float = 0.05) -> Calibration:
    """Fit ``measured = scale * surveyed + offset`` over the target rays (Fig. 102).

    Rays without a return are skipped. Starting from scale 1 and the median offset, rays whose
    residual exceeds ``reject_m`` (a hidden target, a wild range) are dropped and the fit repeated
    (three times).

    Raises:
        ExcavsimError: fewer than two usable target rays (no fit is possible).
    """
    surveyed = geometry.target_ranges.ravel()
    measured = image.target_ranges.ravel()
    use = np.isfinite(measured)
    if use.sum() < 2:
        raise WorldError(f"scanner calibration needs at least two target rays; {int(use.sum())} returned "
                         "(are the targets hidden?)")
    # Start from scale 1 and the median offset (robust to a hidden target), then refit without outliers.
    scale, offset = 1.0, float(np.median(measured[use] - surveyed[use]))
    for _ in range(3):
        resid = measured - (scale * surveyed + offset)
        use = np.isfinite(measured) & (np.abs(resid) <= reject_m)
        if use.sum() < 2 or np.ptp(surveyed[use]) <= 0:
            raise WorldError(f"scanner calibration needs at least two target rays at different ranges; "
                             f"{int(use.sum())} agree (are the targets hidden?)")
        a = np.stack([surveyed[use], np.ones(int(use.sum()))], axis=1)
        (scale, offset), *_ = np.linalg.lstsq(a, measured[use], rcond=None)
    residuals = np.where(use, (measured - offset) / scale - surveyed, np.nan).reshape(geometry.target_ranges.shape)
    return Calibration(float(scale), float(offset), residuals, int(use.sum()))


@dataclasses.dataclass(frozen=True)
class PoseCalibration:
    """The mount's pose error and every image's scale and offset, fitted together to the targets.

    ``position_m`` is the scanner's origin less the surveyed one (x, y; z is not observable from
    targets on vertical walls and stays 0), ``rotation_rad`` the small rotation vector taking the
    surveyed ray directions to the true ones; ``calibrations`` the per-image scale and offset with
    their residuals at the targets after the whole correction.
    """

    position_m: np.ndarray
    rotation_rad: np.ndarray
    calibrations: list[Calibration]

    def origin(self, geometry: ScanGeometry) -> np.ndarray:
        """The corrected scanner origin, world [m]."""
        return geometry.origin + self.position_m

    def directions(self, geometry: ScanGeometry) -> np.ndarray:
        """The corrected image ray directions (n_el, n_az, 3)."""
        d = geometry.directions + np.cross(self.rotation_rad, geometry.directions)
        return d / np.linalg.norm(d, axis=-1, keepdims=True)


def _target_planes(geometry: ScanGeometry) -> tuple[np.ndarray, np.ndarray]:
    """Each target ray's plate: unit normal and a point on it, from the surveyed patch (n_targets, k, 3)."""
    pts = geometry.origin + geometry.target_directions * geometry.target_ranges[..., None]
    normals = np.empty_like(pts)
    centres = np.empty_like(pts)
    for i, patch in enumerate(pts):
        c = patch.mean(axis=0)
        n = np.linalg.svd(patch - c)[2][-1] if len(patch) >= 3 else -geometry.target_directions[i].mean(axis=0)
        normals[i], centres[i] = n, c
    return normals, centres


def calibrate_pose(images: Sequence[RangeImage], geometry: ScanGeometry, *, reject_m: float = 0.05,
                   rotation: bool = False) -> PoseCalibration:
    """Fit the mount's pose error and every image's scale and offset to the target ranges at once.

    The calibration of Hoffman and Krotkov that Singh 1995 §7.1.2 describes ("finding the pose of the
    scanner and the scale and offset parameters that minimizes the error given range readings to
    known points"). A target ray along the surveyed direction ``d`` meets its plate (normal ``n``,
    through ``c``, both from the surveyed patch) at ``t0``; from an origin off by ``dp`` and turned
    by the small rotation ``w`` it meets it at, to first order,
    ``t0 - n.dp / n.d - t0 w.(d x n) / n.d``, read as ``s_j t + b_j`` by image ``j``. The linear
    least squares over all images' target rays (with the rejection of :func:`calibrate`: a hidden
    target, a wild range) gives ``dp`` (x, y), ``w`` and every ``(s_j, b_j)``; the z of ``dp`` does
    not change the ranges to plates on vertical walls, so it stays unknown (the walls' tops, see
    :func:`wall_levelling`, see it).

    Raises:
        ExcavsimError: too few target rays agree for the fit.
    """
    n_img = len(images)
    normals, centres = _target_planes(geometry)
    d = geometry.target_directions.reshape(-1, 3)
    n = normals.reshape(-1, 3)
    t0 = geometry.target_ranges.ravel()
    nd = np.einsum("ij,ij->i", n, d)
    a_pos = -(n / nd[:, None])[:, :2]
    a_rot = -(t0 / nd)[:, None] * np.cross(d, n)
    k = t0.size
    measured = np.concatenate([im.target_ranges.ravel() for im in images])
    n_rot = 3 if rotation else 0
    rows = np.zeros((n_img * k, 2 * n_img + 2 + n_rot))
    for j in range(n_img):
        sl = slice(j * k, (j + 1) * k)
        rows[sl, 2 * j] = t0
        rows[sl, 2 * j + 1] = 1.0
        rows[sl, 2 * n_img:2 * n_img + 2] = a_pos
        if rotation:
            rows[sl, 2 * n_img + 2:] = a_rot
    # Start from the rays within a loose band of their surveyed range (less each image's median
    # offset): a wild range is out, a pose error of centimetres is in; then tighten to reject_m.
    use = np.zeros(measured.size, bool)
    for j in range(n_img):
        sl = slice(j * k, (j + 1) * k)
        dev = measured[sl] - t0
        ok = np.isfinite(dev)
        if ok.any():
            use[sl] = ok & (np.abs(dev - np.median(dev[ok])) <= max(4 * reject_m, 0.2))
    for _ in range(4):
        if use.sum() < rows.shape[1] + 2:
            raise WorldError(f"the pose calibration needs at least {rows.shape[1] + 2} agreeing target rays "
                             f"over {n_img} images; {int(use.sum())} agree (are the targets hidden?)")
        x, *_ = np.linalg.lstsq(rows[use], measured[use], rcond=None)
        resid = measured - rows @ x
        use = np.isfinite(measured) & (np.abs(resid) <= reject_m)
    pos = np.array([x[2 * n_img], x[2 * n_img + 1], 0.0])
    rot = np.asarray(x[2 * n_img + 2:], dtype=float) if rotation else np.zeros(3)
    cals = []
    for j in range(n_img):
        sj, bj = float(x[2 * j]), float(x[2 * j + 1])
        sl = slice(j * k, (j + 1) * k)
        res = np.where(use[sl], resid[sl] / sj, np.nan).reshape(geometry.target_ranges.shape)
        cals.append(Calibration(sj, bj, res, int(use[sl].sum())))
    return PoseCalibration(pos, rot, cals)


def median_ranges(images: Sequence[RangeImage], calibrations: Sequence[Calibration] | None) -> np.ndarray:
    """Per-pixel median across images of the (corrected) ranges, ignoring dropouts (NaN if none)."""
    stack = np.stack([im.ranges for im in images])
    if calibrations is not None:
        scale = np.array([c.scale for c in calibrations])[:, None, None]
        offset = np.array([c.offset for c in calibrations])[:, None, None]
        stack = (stack - offset) / scale
    valid = np.isfinite(stack)
    out = np.full(stack.shape[1:], np.nan)
    any_valid = valid.any(axis=0)
    s = np.sort(np.where(valid, stack, np.inf), axis=0)  # NaNs (inf) last
    n = valid.sum(axis=0)
    k = np.maximum(n - 1, 0)
    lo = np.take_along_axis(s, (k // 2)[None], axis=0)[0]
    hi = np.take_along_axis(s, ((k + 1) // 2)[None], axis=0)[0]
    out[any_valid] = 0.5 * (lo + hi)[any_valid]
    return out


def edge_pixels(ranges: np.ndarray, jump_m: float) -> np.ndarray:
    """Pixels of a range image (n_el, n_az) whose range differs from a 4-neighbour's by more than ``jump_m``.

    The edges of Fig. 96 (bottom left): at a depth discontinuity a beam of finite footprint returns
    a mixed range between the foreground and the background, a point in mid-air. Dropping the
    pixels on both sides of every jump (Fig. 96, bottom right: "pixels that have been filtered
    out") removes them at the cost of a few good ones; a pixel next to a dropout is kept.
    """
    r = np.where(np.isfinite(ranges), ranges, np.nan)
    jump = np.zeros(r.shape, bool)
    with np.errstate(invalid="ignore"):
        d0 = np.abs(np.diff(r, axis=0)) > jump_m
        d1 = np.abs(np.diff(r, axis=1)) > jump_m
    jump[1:] |= d0
    jump[:-1] |= d0
    jump[:, 1:] |= d1
    jump[:, :-1] |= d1
    return jump


def fill_unobserved(heights: np.ndarray, observed: np.ndarray) -> np.ndarray:
    """Fill unobserved cells with the highest observed (or already filled) 8-neighbour, repeatedly."""
    h = np.where(observed, heights, -np.inf)
    known = observed.copy()
    if not known.any():
        raise WorldError("the scans observed no cell of the soil area; is the scanner blocked?")
    while not known.all():
        pad = np.pad(h, 1, constant_values=-np.inf)
        best = np.full(h.shape, -np.inf)
        ny, nx = h.shape
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                if dr or dc:
                    best = np.maximum(best, pad[1 + dr:1 + dr + ny, 1 + dc:1 + dc + nx])
        newly = ~known & np.isfinite(best)
        h[newly] = best[newly]
        known |= newly
    return h


@dataclasses.dataclass(frozen=True)
class Levelling:
    """The height error plane of a scan, fitted to the points on the walls' tops.

    ``z_error = a + b x + c y`` [m] over the box, ``coefficients = (a, b, c)``; ``n_points`` points
    on the wall tops took part, their residual about the plane has RMS ``rms_m``.
    """

    coefficients: tuple[float, float, float]
    n_points: int
    rms_m: float

    def error_at(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        a, b, c = self.coefficients
        return a + b * np.asarray(x) + c * np.asarray(y)


def wall_levelling(points: np.ndarray, geometry: ScanGeometry, *, band_m: float = 0.06, reject_m: float = 0.02,
                   min_points: int = 50) -> Levelling | None:
    """The height error plane of a scan's points (n, 3), from those on the tops of the box's walls.

    The walls' tops are surveyed (``geometry.wall_top_z``, ``wall_thickness_m``): the points whose
    (x, y) lie on them (1 cm in from their edges) and whose height is within ``band_m`` of their
    top are fitted with a plane of the height error (least squares, twice more without the points
    ``reject_m`` off). The scanner mount's misalignment, which the range calibration against the
    targets (:func:`calibrate`) cannot see, tilts and lifts the whole map by a centimetre or two;
    this plane measures it. None when fewer than ``min_points`` points fall on the tops.
    """
    x0, x1, y0, y1 = geometry.area
    t, m = geometry.wall_thickness_m, 0.01
    x, y, z = points[:, 0], points[:, 1], points[:, 2]
    on_x = ((x > x0 - t + m) & (x < x0 - m)) | ((x > x1 + m) & (x < x1 + t - m))
    on_y = ((y > y0 - t + m) & (y < y0 - m)) | ((y > y1 + m) & (y < y1 + t - m))
    top = ((on_x & (y > y0 - t) & (y < y1 + t)) | (on_y & (x > x0 - t) & (x < x1 + t)))
    top &= np.abs(z - geometry.wall_top_z) < band_m
    if top.sum() < min_points:
        return None
    a_mat = np.column_stack([np.ones(int(top.sum())), x[top], y[top]])
    err = z[top] - geometry.wall_top_z
    use = np.ones(len(err), bool)
    for _ in range(3):
        coef, *_ = np.linalg.lstsq(a_mat[use], err[use], rcond=None)
        res = err - a_mat @ coef
        use = np.abs(res) <= reject_m
        if use.sum() < min_points:
            return None
    return Levelling((float(coef[0]), float(coef[1]), float(coef[2])), int(use.sum()),
                     float(np.sqrt(np.mean(res[use] ** 2))))


def build_map(images: Sequence[RangeImage], geometry: ScanGeometry, config: ElevationMapConfig | None = None,
              ) -> tuple[ElevationMap, list[Calibration]]:
    """Turn range images into an elevation map (calibrate, median-filter, bin, fill).

    Returns:
        The map and the calibration of each image.

    Raises:
        ExcavsimError: no images, images of another scanner geometry, or nothing observed.
    """
    config = config or ElevationMapConfig()
    if not images:
        raise UsageError("build_map needs at least one range image")
    for im in images:
        if im.ranges.shape != geometry.image_shape:
            raise UsageError(f"range image of shape {im.ranges.shape} does not match the scanner's "
                             f"{geometry.image_shape}")
    origin, directions = geometry.origin, geometry.directions
    if config.calibrate and config.calibrate_pose:  # the mount's pose too, from the same targets
        pose = calibrate_pose(images, geometry)
        cals = pose.calibrations
        origin, directions = pose.origin(geometry), pose.directions(geometry)
    else:
        cals = [calibrate(im, geometry) for im in images] if config.calibrate else None
    r = median_ranges(images, cals)
    if config.edge_filter_m:  # Fig. 96: the pixels at edges, mixed by the beam's footprint
        r = np.where(edge_pixels(r, config.edge_filter_m), np.nan, r)
    pts = origin + directions * r[..., None]
    ok = np.isfinite(r)
    if config.level:  # the height error plane of the mount's misalignment, from the walls' tops
        levelling = wall_levelling(pts[ok], geometry)
        if levelling is not None:
            pts = pts.copy()
            pts[..., 2] -= levelling.error_at(pts[..., 0], pts[..., 1])
    x0, x1, y0, y1 = geometry.area
    cell = config.cell_size_m
    nx = int(round((x1 - x0) / cell))
    ny = int(round((y1 - y0) / cell))
    p = pts[ok]
    inside = ((p[:, 0] > x0 + WALL_MARGIN_M) & (p[:, 0] < x1 - WALL_MARGIN_M)
              & (p[:, 1] > y0 + WALL_MARGIN_M) & (p[:, 1] < y1 - WALL_MARGIN_M))
    p = p[inside]
    col = np.clip(((p[:, 0] - x0) / cell).astype(np.int64), 0, nx - 1)
    row = np.clip(((p[:, 1] - y0) / cell).astype(np.int64), 0, ny - 1)
    idx = row * nx + col
    count = np.bincount(idx, minlength=nx * ny)
    # per-cell median of the point heights: robust to the few wall points a misaligned scanner
    # still places inside the margin
    order = np.lexsort((p[:, 2], idx))
    z_sorted = p[order, 2]
    start = np.concatenate([[0], np.cumsum(count)[:-1]])
    has = count > 0
    lo = start + (count - 1) // 2
    hi = start + count // 2
    med = np.full(nx * ny, np.nan)
    med[has] = 0.5 * (z_sorted[lo[has]] + z_sorted[hi[has]])
    observed = has.reshape(ny, nx)
    heights = fill_unobserved(med.reshape(ny, nx), observed)
    emap = ElevationMap(float(x0), float(y0), float(cell), heights, observed, float(images[-1].time))
    return emap, cals or []


class Scanner(Protocol):
    """A range scanner as the mind sees it: its geometry, and a range image taken at a time [s]
    (:class:`~excavsim.world.scanner.LaserScanner` is one; the mind never imports the world)."""

    geometry: ScanGeometry

    def scan(self, time: float = 0.0) -> RangeImage: ...


def scan_map(scanner: Scanner, time: float, config: ElevationMapConfig, n_scans: int | None = None,
             timings: dict[str, float] | None = None) -> tuple[ElevationMap, list[Calibration]]:
    """Take ``n_scans`` range images (default ``config.n_scans``) at ``time`` [s] and build their
    elevation map (:func:`build_map`): the one "scan, then map" of every task (trenching, loading
    from a pile, truck loading). Returns the map and the calibration of each image; ``timings``, when
    given, receives the wall time of the acquisition and of the map (``acquisition_wall_s``,
    ``map_wall_s``: Singh 1995 Table 7's first two rows)."""
    n = config.n_scans if n_scans is None else n_scans
    t0 = _time.perf_counter()
    images = [scanner.scan(time) for _ in range(n)]
    t1 = _time.perf_counter()
    out = build_map(images, scanner.geometry, config)
    if timings is not None:
        timings["acquisition_wall_s"], timings["map_wall_s"] = t1 - t0, _time.perf_counter() - t1
    return out


@dataclasses.dataclass(frozen=True)
class MapAccuracy:
    """Errors of a map against the true terrain (privileged) [m]."""

    rms_m: float
    max_m: float
    mean_m: float
    rms_filled_m: float
    observed_fraction: float
    target_rms_m: float

    def summary(self) -> str:
        return (f"map error RMS {100 * self.rms_m:.2f} cm, max {100 * self.max_m:.2f} cm, bias "
                f"{100 * self.mean_m:+.2f} cm over {100 * self.observed_fraction:.0f} % observed cells; "
                f"filled cells RMS {100 * self.rms_filled_m:.2f} cm; target residual RMS "
                f"{100 * self.target_rms_m:.2f} cm")


def true_cell_heights(emap: ElevationMap, surface_z, samples: int = 4) -> np.ndarray:
    """Mean true surface height over each map cell, from ``surface_z(x, y)`` on a sub-grid."""
    xc, yc = emap.centres()
    off = ((np.arange(samples) + 0.5) / samples - 0.5) * emap.cell
    xx = xc[None, :, None, None] + off[None, None, None, :]
    yy = yc[:, None, None, None] + off[None, None, :, None]
    xx, yy = np.broadcast_arrays(xx, yy)
    return surface_z(xx, yy).mean(axis=(2, 3))


def map_accuracy(emap: ElevationMap, surface_z, calibrations: Sequence[Calibration] = ()) -> MapAccuracy:
    """Compare a map with the true surface ``surface_z(x, y)`` (e.g. ``SoilGrid.surface_z``)."""
    truth = true_cell_heights(emap, surface_z)
    err = emap.heights - truth
    obs = emap.observed
    e = err[obs]
    f = err[~obs]
    res = np.concatenate([c.residuals.ravel() for c in calibrations]) if calibrations else np.array([np.nan])
    res = res[np.isfinite(res)]
    return MapAccuracy(
        rms_m=float(np.sqrt(np.mean(e * e))), max_m=float(np.abs(e).max()), mean_m=float(e.mean()),
        rms_filled_m=float(np.sqrt(np.mean(f * f))) if f.size else 0.0, observed_fraction=float(obs.mean()),
        target_rms_m=float(np.sqrt(np.mean(res * res))) if res.size else float("nan"),
    )
