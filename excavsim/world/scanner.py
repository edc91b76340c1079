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

The testbed's further errors, all off by default (the default scanner's ranges are bit-identical to
those before they existed; ``configs/sensing_testbed.yaml`` turns them on; magnitudes and sources in
docs/notes/2026-12-02-scanner-errors.md). Each random one draws from its own stream, derived from the
episode's seed sequence, so turning one on changes no other's draws:

* **beam footprint and mixed pixels** (assumed, a Gaussian beam of ``beam_divergence_mrad``): each
  pixel casts a central ray and a ring of six at half the divergence; the return is the mean of their
  ranges weighted by their returned power (beam weight x reflectance x cos / range^2), as an AM-CW
  scanner's phase averages (Singh 1995 §7.1.2 names the Perceptron; the thesis' Fig. 96 filters the
  pixels at edges). On a smooth surface the mean is the centre's range; at a depth discontinuity (a
  wall's top edge, a trench's lip) it lands between foreground and background: a mixed pixel;
* **incidence bias** (assumed): ``incidence_bias_m * (1 / cos - 1)``, long, on oblique surfaces (the
  elongated footprint's centroid of returned power lies beyond its centre);
* **reflectance bias** (assumed, "range walk"): ``reflectance_bias_m * ln(soil_reflectance / rho)``:
  the dark target plates (Fig. 101's "dark spots") read long relative to the soil, so the range
  calibration against them carries an offset into the soil's heights;
* **reflectance image** (Fig. 96, top right): brightness ``rho cos (3 m / range)^2`` clipped to [0, 1]
  plus noise (stream ``reflectance noise``), the soil's reflectance textured per cell per episode
  (stream ``soil texture``);
* **occlusion**: truthful from the cast (rays stop at the soil and the walls); with a footprint, the
  shadow's edge is mixed;
* **mount position error** (assumed, stream ``mount``): the scanner's true origin is off the surveyed
  one by ``N(0, mount_offset_m)`` per axis per episode. The range calibration's scale and offset
  (Fig. 102) absorb only its part along the rays; the mind's pose calibration against the same
  targets (:func:`excavsim.sensing.elevation.calibrate_pose`) finds its x and y, not its z (the
  targets are on vertical walls), which the walls' tops (levelling) see.

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
BRIGHTNESS_RANGE_M = 3.0  # range at which a surface of reflectance rho, seen head on, has brightness rho
RING_RAYS = 6  # rays in the footprint's ring, at half the divergence from the centre
RING_WEIGHT = math.exp(-2.0)  # a Gaussian beam's intensity at its 1/e^2 half-angle, relative to the centre
# the testbed terms' random streams (spawn keys under the episode's seed sequence)
STREAM_MOUNT, STREAM_TEXTURE, STREAM_REFLECTANCE = 1, 2, 3


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


def _occluder_geoms(model: mujoco.MjModel) -> list[int]:
    """The geoms of the box's walls and target plates, in model order."""
    body = element_id(model, "body", constants.SOIL_BOX_BODY)
    return [g for g in range(model.ngeom)
            if model.geom_bodyid[g] == body and model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX
            and not (mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or "").startswith("scanner")]


def _occluder_names(model: mujoco.MjModel) -> list[str]:
    """The names of :func:`_occluders`' rows."""
    return [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or "" for g in _occluder_geoms(model)]


def _occluders(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    """The box's walls and target plates as rows (centre 3, rotation 9, half sizes 3)."""
    rows = [np.r_[data.geom_xpos[g], data.geom_xmat[g], model.geom_size[g]] for g in _occluder_geoms(model)]
    return np.asarray(rows, dtype=float).reshape(-1, 15)


def error_stream(rng: np.random.Generator, term: int) -> np.random.Generator:
    """An independent generator for one error term, derived from ``rng``'s seed sequence.

    ``rng`` itself is neither advanced nor changed, so the scanner's original draws (noise, drift,
    misalignment, dropouts) stay those of the seed whichever terms are on.

    Raises:
        ValueError: ``rng`` was not made from a seed sequence (e.g. ``np.random.default_rng(seed)``).
    """
    ss = getattr(rng.bit_generator, "seed_seq", None)
    if not isinstance(ss, np.random.SeedSequence):
        raise ValueError("the scanner's generator must come from a seed (np.random.default_rng(seed)); "
                         f"its bit generator has no seed sequence ({type(ss).__name__})")
    return np.random.default_rng(np.random.SeedSequence(ss.entropy, spawn_key=(*ss.spawn_key, 0x5CA, term)))


def _ring(dirs: np.ndarray, half_angle: float) -> list[np.ndarray]:
    """Six unit directions at ``half_angle`` [rad] around each of ``dirs`` (n, 3), one array per ring position."""
    up = np.array([0.0, 0.0, 1.0])
    e1 = np.cross(dirs, up)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(dirs, e1)
    out = []
    for k in range(RING_RAYS):
        phi = 2 * math.pi * k / RING_RAYS
        d = dirs + math.tan(half_angle) * (math.cos(phi) * e1 + math.sin(phi) * e2)
        out.append(np.ascontiguousarray(d / np.linalg.norm(d, axis=1, keepdims=True)))
    return out


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
        # the testbed's terms (all off by default: then nothing below draws or casts anything)
        self.mount_offset = np.zeros(3)
        if config.mount_offset_m:
            self.mount_offset = error_stream(rng, STREAM_MOUNT).normal(0.0, config.mount_offset_m, 3)
        self._origin = origin + self.mount_offset  # where the rays really start
        self._ring_dirs = (_ring(self._true_dirs, 0.5e-3 * config.beam_divergence_mrad)
                           if config.beam_divergence_mrad else [])
        self._texture = None
        if config.soil_reflectance_texture and config.testbed_errors:
            z = error_stream(rng, STREAM_TEXTURE).normal(0.0, config.soil_reflectance_texture, grid.shape)
            self._texture = np.clip(1.0 + z, 0.1, 2.0)
        self._refl_rng = error_stream(rng, STREAM_REFLECTANCE) if config.reflectance_noise else None
        plates = [i for i, name in enumerate(_occluder_names(model)) if name.endswith("_plate")]
        self._plates = self.boxes[plates]
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
        raycast.cast(g.heights, g.x0, g.y0, g.cell, g.z0, ztop, self.boxes, self._origin, dirs,
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
        raycast.affected(self._origin, dirs, t_end, x_lo, x_hi, y_lo, y_hi, z_hi, todo)
        idx = np.nonzero(todo)[0]
        if idx.size:
            t, cos, kind = self._cast(np.ascontiguousarray(dirs[idx]), entry.ztop)
            entry.t[idx], entry.cos[idx], entry.kind[idx] = t, cos, kind
        entry.heights[...] = g.heights
        self.cast_stats["rays"] += int(idx.size)

    def reflectance_of(self, dirs: np.ndarray, t: np.ndarray, kind: np.ndarray) -> np.ndarray:
        """The reflectance of what each ray (``dirs`` (n, 3), range ``t``, hit ``kind``) hits; NaN if nothing.

        Soil: ``soil_reflectance`` times the episode's texture at the cell hit; boxes: the target
        plates' reflectance where the hit lies on a plate, the walls' elsewhere.
        """
        c = self.config
        rho = np.full(t.shape, np.nan)
        soil = kind == raycast.HIT_SOIL
        box = kind == raycast.HIT_BOX
        rho[soil] = c.soil_reflectance
        rho[box] = c.wall_reflectance
        if self._texture is not None and soil.any():
            g = self.grid
            p = self._origin + dirs[soil] * t[soil, None]
            col = np.clip(((p[:, 0] - g.x0) / g.cell).astype(np.int64), 0, g.shape[1] - 1)
            row = np.clip(((p[:, 1] - g.y0) / g.cell).astype(np.int64), 0, g.shape[0] - 1)
            rho[soil] *= self._texture[row, col]
        if box.any() and len(self._plates):
            idx = np.nonzero(box)[0]
            p = self._origin + dirs[idx] * t[idx, None]
            on_plate = np.zeros(idx.size, bool)
            for b in self._plates:  # inside the plate's box, 2 mm slack
                local = (p - b[:3]) @ b[3:12].reshape(3, 3)
                on_plate |= np.all(np.abs(local) <= b[12:15] + 2e-3, axis=1)
            rho[idx[on_plate]] = c.target_reflectance
        return rho

    def _testbed_returns(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Ranges, incidence cosines and brightness of the misaligned rays with the testbed's terms.

        The footprint's rays (centre, and the ring when the beam diverges) each return a range
        biased by incidence and reflectance; the pixel's range is their mean weighted by returned
        power, its brightness that power relative to the beam's (see the module's docstring). The
        cosine is the centre ray's (for the grazing dropouts). Ranges are inf where nothing returned.
        """
        c = self.config
        cos_floor = math.cos(math.radians(c.grazing_dropout_deg))
        num = den = 0.0
        weights = [1.0] + [RING_WEIGHT] * len(self._ring_dirs)
        cos_c = None
        for w, dirs in zip(weights, [self._true_dirs, *self._ring_dirs]):
            t, cos, kind = self._cached(dirs)
            if cos_c is None:
                cos_c = cos
            hit = np.isfinite(t)
            rho = self.reflectance_of(dirs, t, kind)
            r = np.where(hit, t, 0.0)
            cos_h = np.maximum(cos, cos_floor)
            if c.incidence_bias_m:
                r = r + c.incidence_bias_m * (1.0 / cos_h - 1.0)
            if c.reflectance_bias_m:
                r = r + c.reflectance_bias_m * np.log(c.soil_reflectance / np.where(hit, rho, c.soil_reflectance))
            power = np.where(hit, w * np.nan_to_num(rho) * cos * (BRIGHTNESS_RANGE_M / np.where(hit, t, 1.0)) ** 2,
                             0.0)
            num = num + power * r
            den = den + power
        ranges = np.where(den > 0, num / np.where(den > 0, den, 1.0), np.inf)
        return ranges, cos_c, den / sum(weights)

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
        c = self.config
        brightness = None
        if noise and c.testbed_errors:
            t, cos, brightness = self._testbed_returns()
        else:
            t, cos, _ = self._cached(self._true_dirs if noise else self._surveyed_dirs)
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
        reflectance = None
        if noise and c.reflectance_image:
            b = brightness[:n_img]
            if self._refl_rng is not None:
                b = b + self._refl_rng.normal(0.0, c.reflectance_noise, n_img)
            reflectance = np.where(np.isfinite(r[:n_img]), np.clip(b, 0.0, 1.0), np.nan).reshape(
                self.geometry.image_shape)
        return RangeImage(float(time), r[:n_img].reshape(self.geometry.image_shape),
                          r[n_img:].reshape(self.geometry.target_ranges.shape), reflectance)
