"""The simulated laser range scanner: true ranges from the world, with the errors of §7.1.2.

The scanner sits at the ``scanner`` site of the soil box (a Perceptron-like range scanner on a mast
beyond the near wall; the site's +z is its boresight). Each scan casts a grid of rays, uniform in
azimuth and elevation over the box plus a margin, and a small patch of rays at each surveyed target
on the walls. Occlusion is truthful: rays stop at the soil (MuJoCo's heightfield triangles), the
walls and the target plates (:mod:`excavsim.world.raycast`). The arm is not in this scene model:
the executor parks it out of view before a scan (Singh 1995 §7.2).

Errors (``configs/sensing.yaml``):

* Gaussian range noise (default sigma 1 cm);
* a slowly drifting scale and offset, a temperature-like random walk between scans (Fig. 98):
  ``e_k+1 = m e_k + N(0, s)`` for the scale error and the offset, with memory ``m``;
* a fixed misalignment of the mount (default sigma 0.15 deg about each axis, drawn per episode):
  the robot maps with the surveyed directions while the rays go slightly elsewhere, a systematic
  error that neither calibration nor the median removes and that, with the rest, gives the
  thesis' ~2 cm residual map error;
* dropouts at grazing incidence (beyond 80 deg from the surface normal), random dropouts, and rare
  wild ranges (outliers) that the median over scans removes; no return beyond the maximum range.

:class:`LaserScanner` belongs to the world: it reads the true terrain. What the robot's mind knows
of it is :class:`ScanGeometry` (the calibrated pose, the ray directions and the surveyed target
ranges) and what it receives is :class:`RangeImage`.
"""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np

from excavsim import constants
from excavsim.config import ScannerConfig
from excavsim.handoff.maps import RangeImage, ScanGeometry
from excavsim.readouts import element_id
from excavsim.world import raycast
from excavsim.world.terrain import SoilGrid


ZTOP_STEP_M = 0.1  # the cast's upper bound on the terrain moves in steps of this (see LaserScanner._ztop)


@dataclasses.dataclass
class _CastCache:
    """The true ranges of one ray set on the terrain ``heights``, cast with the bound ``ztop``."""

    heights: np.ndarray
    ztop: float
    t: np.ndarray
    cos: np.ndarray
    kind: np.ndarray


def _small_rotation(angles: np.ndarray) -> np.ndarray:
    """Rotation matrix of the rotation vector ``angles`` (3,) [rad] (Rodrigues)."""
    theta = float(np.linalg.norm(angles))
    if theta == 0.0:
        return np.eye(3)
    k = angles / theta
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(theta) * kx + (1 - np.cos(theta)) * kx @ kx


def _occluders(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    """The box's walls and target plates as rows (centre 3, rotation 9, half sizes 3)."""
    body = element_id(model, "body", constants.SOIL_BOX_BODY)
    rows = []
    for g in range(model.ngeom):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or ""
        if (model.geom_bodyid[g] == body and model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX
                and not name.startswith("scanner")):
            rows.append(np.r_[data.geom_xpos[g], data.geom_xmat[g], model.geom_size[g]])
    return np.asarray(rows, dtype=float).reshape(-1, 15)


class LaserScanner:
    """A range scanner looking at the soil box (world side: it reads the true terrain).

    Args:
        model: the compiled scene (scanner site, walls, targets, soil hfield).
        grid: the true terrain.
        config: scanner settings and error model.
        rng: the episode's generator for noise and drift.
    """

    def __init__(self, model: mujoco.MjModel, grid: SoilGrid, config: ScannerConfig, rng: np.random.Generator):
        self.grid = grid
        self.config = config
        self.rng = rng
        data = mujoco.MjData(model)
        mujoco.mj_kinematics(model, data)
        site = element_id(model, "site", constants.SCANNER_SITE)
        origin = data.site_xpos[site].copy()
        rot = data.site_xmat[site].reshape(3, 3).copy()
        self.boxes = np.ascontiguousarray(_occluders(model, data))
        wall_top = float(max(self.boxes[:, 2] + self.boxes[:, 14])) if len(self.boxes) else 1.0
        walls = self.boxes[np.abs(self.boxes[:, 2] + self.boxes[:, 14] - wall_top) < 1e-3]
        thickness = float(2 * walls[:, 12:14].min()) if len(walls) else 0.05
        area = (grid.x0, grid.x1, grid.y0, grid.y1)
        # field of view: the soil volume's corners (floor to wall top) plus a margin
        corners = np.array([[x, y, z] for x in area[:2] for y in area[2:] for z in (grid.z0, wall_top)])
        local = (corners - origin) @ rot
        az = np.arctan2(local[:, 0], local[:, 2])
        el = np.arctan2(local[:, 1], np.hypot(local[:, 0], local[:, 2]))
        m = np.radians(config.margin_deg)
        a = np.linspace(az.min() - m, az.max() + m, config.n_azimuth)
        e = np.linspace(el.min() - m, el.max() + m, config.n_elevation)
        ee, aa = np.meshgrid(e, a, indexing="ij")
        d_local = np.stack([np.cos(ee) * np.sin(aa), np.sin(ee), np.cos(ee) * np.cos(aa)], axis=-1)
        directions = d_local @ rot.T
        t_dirs, t_ranges = self._target_rays(model, data, origin)
        self.geometry = ScanGeometry(origin, np.ascontiguousarray(directions), t_dirs, t_ranges, area, wall_top,
                                     thickness)
        self.scale_error = 0.0
        self.offset = 0.0
        # The mount's true orientation differs from the surveyed one by a small fixed rotation.
        self.misalignment = _small_rotation(rng.normal(0.0, np.radians(config.pose_error_deg), 3))
        self._surveyed_dirs = np.ascontiguousarray(np.concatenate([directions.reshape(-1, 3), t_dirs.reshape(-1, 3)]))
        self._true_dirs = np.ascontiguousarray(self._surveyed_dirs @ self.misalignment.T)
        self._cache: dict[int, _CastCache] = {}
        self.cast_stats = {"full": 0, "reused": 0, "rays": 0}  # casts from scratch, reuses, rays cast

    def _target_rays(self, model: mujoco.MjModel, data: mujoco.MjData,
                     origin: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        k = self.config.target_rays
        offsets = np.linspace(-0.02, 0.02, k) if k > 1 else np.zeros(1)
        dirs, ranges = [], []
        for i in range(constants.N_SURVEY_TARGETS):
            site = element_id(model, "site", f"{constants.SURVEY_TARGET_SITE_PREFIX}{i}")
            plate = element_id(model, "geom", f"{constants.SURVEY_TARGET_SITE_PREFIX}{i}_plate")
            centre = data.site_xpos[site]
            axes = data.geom_xmat[plate].reshape(3, 3)  # columns: the plate's x, y (in plane), z (normal)
            pts = np.array([centre + u * axes[:, 0] + v * axes[:, 1] for v in offsets for u in offsets])
            vec = pts - origin
            rng_ = np.linalg.norm(vec, axis=1)
            dirs.append(vec / rng_[:, None])
            ranges.append(rng_)
        return np.asarray(dirs), np.asarray(ranges)

    # -- scanning -------------------------------------------------------------------------------
    def _ztop(self) -> float:
        """The heightfield's upper bound for the cast: the highest sample rounded up to ``ZTOP_STEP_M``.

        Rounded so that it stays put while the spoil pile grows within a step: the walk of every
        ray starts where it crosses this height, and an unchanged start is what lets
        :meth:`true_ranges` reuse the ranges of rays the terrain's change cannot reach.
        """
        g = self.grid
        return g.z0 + math.ceil(float(g.heights.max()) / ZTOP_STEP_M + 1e-9) * ZTOP_STEP_M

    def _cast(self, dirs: np.ndarray, ztop: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        n = dirs.shape[0]
        t, cos, kind = np.empty(n), np.empty(n), np.empty(n, np.int64)
        g = self.grid
        raycast.cast(g.heights, g.x0, g.y0, g.cell, g.z0, ztop, self.boxes, self.geometry.origin, dirs,
                     self.config.max_range_m, t, cos, kind)
        return t, cos, kind

    def true_ranges(self, directions: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Exact ranges, incidence cosines and hit kinds along rays (privileged; image + target rays).

        Returns flat arrays over ``directions`` (n, 3, world frame), by default the image rays then the
        target rays as the misaligned scanner actually casts them.

        The scanner's own ray sets (the misaligned and the surveyed directions) are cast once per
        terrain: the scans of one map see the same terrain (the arm is parked out of view), so they
        reuse the ranges; after a dig only the rays that pass over the changed cells low enough to
        touch them are recast (:func:`~excavsim.world.raycast.affected`), and the result equals a
        full cast to the bit (a test holds them equal). Callers get copies.
        """
        if directions is not None:
            return self._cast(np.ascontiguousarray(directions, dtype=float), self._ztop())
        return self._cached(self._true_dirs)

    def _cached(self, dirs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        g = self.grid
        ztop = self._ztop()
        entry = self._cache.get(id(dirs))
        if entry is not None and entry.ztop == ztop and entry.heights.shape == g.heights.shape:
            changed = entry.heights != g.heights
            if changed.any():
                self._recast(entry, dirs, changed)
            self.cast_stats["reused"] += 1
        else:
            t, cos, kind = self._cast(dirs, ztop)
            entry = _CastCache(g.heights.copy(), ztop, t, cos, kind)
            self._cache[id(dirs)] = entry
            self.cast_stats["full"] += 1
            self.cast_stats["rays"] += dirs.shape[0]
        return entry.t.copy(), entry.cos.copy(), entry.kind.copy()

    def _recast(self, entry: _CastCache, dirs: np.ndarray, changed: np.ndarray) -> None:
        """Recast the rays of ``entry`` that the ``changed`` samples can reach; update it in place."""
        g = self.grid
        rows, cols = np.nonzero(changed)
        # a changed sample is a corner of the cells around it: the window spans one cell either side
        pad = 1e-9  # rays grazing the window's edge count as crossing it
        x_lo, x_hi = g.x0 + (cols.min() - 1) * g.cell - pad, g.x0 + (cols.max() + 1) * g.cell + pad
        y_lo, y_hi = g.y0 + (rows.min() - 1) * g.cell - pad, g.y0 + (rows.max() + 1) * g.cell + pad
        window = (slice(max(rows.min() - 1, 0), rows.max() + 2), slice(max(cols.min() - 1, 0), cols.max() + 2))
        z_hi = g.z0 + max(float(entry.heights[window].max()), float(g.heights[window].max())) + 1e-9
        t_end = np.where(np.isfinite(entry.t), entry.t, self.config.max_range_m)
        todo = np.empty(dirs.shape[0], np.bool_)
        raycast.affected(self.geometry.origin, dirs, t_end, x_lo, x_hi, y_lo, y_hi, z_hi, todo)
        idx = np.nonzero(todo)[0]
        if idx.size:
            t, cos, kind = self._cast(np.ascontiguousarray(dirs[idx]), entry.ztop)
            entry.t[idx], entry.cos[idx], entry.kind[idx] = t, cos, kind
        entry.heights[...] = g.heights
        self.cast_stats["rays"] += int(idx.size)

    def drift(self) -> None:
        """Advance the scale and offset errors by one scan (the temperature-like random walk)."""
        c = self.config
        self.scale_error = c.drift_memory * self.scale_error + self.rng.normal(0.0, c.scale_drift_per_scan)
        self.offset = c.drift_memory * self.offset + self.rng.normal(0.0, c.offset_drift_m_per_scan)

    def scan(self, time: float = 0.0, *, noise: bool = True) -> RangeImage:
        """Take one range image (after advancing the drift).

        ``noise=False`` gives an ideal scanner: exact ranges along the surveyed directions (no
        misalignment, drift, noise, dropouts or outliers; rays that hit nothing still return NaN).
        """
        t, cos, _ = self._cached(self._true_dirs if noise else self._surveyed_dirs)
        c = self.config
        r = t.copy()
        r[~np.isfinite(r)] = np.nan
        if noise:
            self.drift()
            n = r.size
            r = (1.0 + self.scale_error) * r + self.offset + self.rng.normal(0.0, c.range_noise_m, n)
            grazing = cos < np.cos(np.radians(c.grazing_dropout_deg))
            dropped = grazing | (self.rng.random(n) < c.dropout_probability)
            wild = self.rng.random(n) < c.outlier_probability
            r[wild] = self.rng.uniform(0.5, c.max_range_m, int(wild.sum()))
            r[dropped] = np.nan
            r[r > c.max_range_m] = np.nan
        n_img = self.geometry.directions.shape[0] * self.geometry.directions.shape[1]
        return RangeImage(float(time), r[:n_img].reshape(self.geometry.image_shape),
                          r[n_img:].reshape(self.geometry.target_ranges.shape))
