"""Fast reachability lookup over (z, pitch) (Singh 1995 App. A1-3, Fig. A-6).

The z axis and the pitch axis are cut into cells (1 cm and 1 degree). For each cell centre the table
stores the radial distances x at which the tip pose (x, z, pitch) is reachable by exact elbow-up IK
within joint limits. A candidate pose is reachable when ``x_min <= x <= x_max`` in its cell. The
thesis assumes the reachable x values of a cell form one interval; near the ends of the pitch range
and behind the waist they do not, so each cell keeps up to four intervals
(:attr:`ReachabilityTable.n_gapped` counts the split cells).

Building the table costs a few seconds; it is cached on disk, keyed by a hash of the arm's
kinematic parameters and the table's resolution, so a changed model never reuses a stale table.
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
import pathlib
import tempfile

import numpy as np

from excavsim.robot.kinematics import PlanarArm

_FORMAT_VERSION = b"reach-v2"


@dataclasses.dataclass(frozen=True)
class TableSpec:
    """Extent and resolution of the table.

    Attributes:
        z_min_m, z_max_m, dz_m: tip heights covered (cell centres) and their spacing [m].
        pitch_min_deg, pitch_max_deg, dpitch_deg: pitches covered and spacing [deg].
        x_min_m, x_max_m, dx_scan_m: radial range scanned and the scan step before refinement [m].
        refine_iters: bisection steps that refine each interval end (the end is known to
            dx_scan_m / 2**refine_iters).
    """

    z_min_m: float = -0.30
    z_max_m: float = 2.50
    dz_m: float = 0.01
    pitch_min_deg: float = -120.0
    pitch_max_deg: float = 120.0
    dpitch_deg: float = 1.0
    x_min_m: float = -0.50
    x_max_m: float = 3.50
    dx_scan_m: float = 0.02
    refine_iters: int = 10

    @property
    def z_centres(self) -> np.ndarray:
        return self.z_min_m + self.dz_m * np.arange(int(round((self.z_max_m - self.z_min_m) / self.dz_m)) + 1)

    @property
    def pitch_centres(self) -> np.ndarray:
        """Pitch cell centres [rad]."""
        n = int(round((self.pitch_max_deg - self.pitch_min_deg) / self.dpitch_deg)) + 1
        return np.radians(self.pitch_min_deg + self.dpitch_deg * np.arange(n))

    def key(self) -> bytes:
        return np.array(dataclasses.astuple(self), dtype=float).tobytes()


@dataclasses.dataclass(frozen=True, eq=False)
class ReachabilityTable:
    """Reachable x intervals per (z, pitch) cell.

    The thesis stores one interval [x_min, x_max] per cell; here each cell keeps up to
    ``max_intervals`` intervals so that cells whose reachable set is split (at extreme pitches, or
    behind the waist) stay exact. Unused slots are NaN.

    Attributes:
        spec: the table's extent and resolution.
        x_lo, x_hi: (nz, npitch, max_intervals) interval ends [m].
        n_gapped: cells whose reachable x values form more than one interval.
        n_merged: cells with more intervals than slots; their last intervals were merged (the
            table over-approximates there).
    """

    spec: TableSpec
    x_lo: np.ndarray
    x_hi: np.ndarray
    n_gapped: int
    n_merged: int

    @classmethod
    def build(cls, arm: PlanarArm, spec: TableSpec = TableSpec(), *, max_intervals: int = 4) -> ReachabilityTable:
        """Build the table from exact IK (vectorized over all cells, scanning x, then bisecting each end)."""
        zz, pp = np.meshgrid(spec.z_centres, spec.pitch_centres, indexing="ij")
        xs = np.arange(spec.x_min_m, spec.x_max_m + 0.5 * spec.dx_scan_m, spec.dx_scan_m)
        shape, kmax = zz.shape, max_intervals
        start = np.full(shape + (kmax,), -1, dtype=np.int64)  # first feasible scan index of each run
        stop = np.full(shape + (kmax,), -1, dtype=np.int64)  # last feasible scan index of each run
        runs = np.zeros(shape, dtype=np.int64)
        prev = np.zeros(shape, dtype=bool)
        for k, x in enumerate(xs):
            ok = arm.reachable(np.stack([np.full(shape, x), zz, pp], axis=-1))
            rise = np.nonzero(ok & ~prev)
            slot = np.minimum(runs[rise], kmax - 1)  # beyond the last slot: extend (merge into) it
            fresh = runs[rise] < kmax
            start[rise + (slot,)] = np.where(fresh, k, start[rise + (slot,)])
            runs[rise] += 1
            live = np.nonzero(ok)
            stop[live + (np.minimum(runs[live], kmax) - 1,)] = k
            prev = ok

        z3, p3 = zz[..., None], pp[..., None]

        def refine(inside: np.ndarray, outward: int) -> np.ndarray:
            """Bisect between a feasible scan sample and its infeasible neighbour."""
            a = xs[np.clip(inside, 0, len(xs) - 1)]
            b = a + outward * spec.dx_scan_m
            for _ in range(spec.refine_iters):
                mid = 0.5 * (a + b)
                ok = arm.reachable(np.stack(np.broadcast_arrays(mid, z3, p3), axis=-1))
                a, b = np.where(ok, mid, a), np.where(ok, b, mid)
            return a

        used = start >= 0
        x_lo = np.where(used & (start > 0), refine(start, -1), xs[0])
        x_hi = np.where(used & (stop < len(xs) - 1), refine(stop, +1), xs[-1])
        return cls(spec=spec, x_lo=np.where(used, x_lo, np.nan), x_hi=np.where(used, x_hi, np.nan),
                   n_gapped=int(np.sum(runs > 1)), n_merged=int(np.sum(runs > kmax)))

    @property
    def x_min(self) -> np.ndarray:
        """Smallest reachable x per cell, (nz, npitch) [m] (NaN where none)."""
        return _nan_reduce(np.nanmin, self.x_lo)

    @property
    def x_max(self) -> np.ndarray:
        """Largest reachable x per cell, (nz, npitch) [m] (NaN where none)."""
        return _nan_reduce(np.nanmax, self.x_hi)

    def cell_index(self, z: np.ndarray, pitch: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Nearest cell (iz, ip) of each (z, pitch) and whether it lies inside the table."""
        s = self.spec
        iz = np.rint((np.asarray(z) - s.z_min_m) / s.dz_m).astype(np.int64)
        ip = np.rint((np.degrees(np.asarray(pitch)) - s.pitch_min_deg) / s.dpitch_deg).astype(np.int64)
        inside = (iz >= 0) & (iz < self.x_lo.shape[0]) & (ip >= 0) & (ip < self.x_lo.shape[1])
        return np.where(inside, iz, 0), np.where(inside, ip, 0), inside

    def contains(self, pose: np.ndarray) -> np.ndarray:
        """Table lookup of reachability for poses (..., 3) of (x, z, pitch) [m, m, rad].

        Poses outside the table's (z, pitch) extent are reported unreachable.
        """
        pose = np.asarray(pose, dtype=float)
        with np.errstate(invalid="ignore"):
            iz, ip, inside = self.cell_index(pose[..., 1], pose[..., 2])
            lo, hi = self.x_lo[iz, ip], self.x_hi[iz, ip]  # (..., max_intervals)
            x = pose[..., 0, None]
            return inside & np.any((x >= lo) & (x <= hi), axis=-1)

    # ------------------------------------------------------------------ cache
    @staticmethod
    def cache_key(arm: PlanarArm, spec: TableSpec) -> str:
        """Hash of the arm's parameters and the table spec."""
        return hashlib.sha256(_FORMAT_VERSION + arm.fingerprint() + spec.key()).hexdigest()[:20]

    def save(self, path: pathlib.Path) -> None:
        """Write atomically (a temporary file renamed into place)."""
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".npz.tmp")
        try:
            with os.fdopen(fd, "wb") as f:
                np.savez(f, x_lo=self.x_lo, x_hi=self.x_hi, n_gapped=self.n_gapped, n_merged=self.n_merged,
                         spec=np.array(dataclasses.astuple(self.spec), dtype=float))
            os.replace(tmp, path)
        finally:
            if os.path.exists(tmp):
                os.unlink(tmp)

    @classmethod
    def load(cls, path: pathlib.Path, spec: TableSpec) -> ReachabilityTable:
        with np.load(path) as data:
            if not np.array_equal(data["spec"], np.array(dataclasses.astuple(spec), dtype=float)):
                raise ValueError(f"{path} holds a table of another spec")
            return cls(spec=spec, x_lo=data["x_lo"], x_hi=data["x_hi"], n_gapped=int(data["n_gapped"]),
                       n_merged=int(data["n_merged"]))


def _nan_reduce(fn, a: np.ndarray) -> np.ndarray:
    """Reduce over the interval axis, NaN where a cell has no interval (without numpy's warning)."""
    empty = np.all(np.isnan(a), axis=-1)
    fill = np.where(empty, 0.0, a[..., 0])[..., None]  # slot 0 is used whenever any slot is
    filled = np.where(np.isnan(a), fill, a)
    return np.where(empty, np.nan, fn(filled, axis=-1))


def default_cache_dir() -> pathlib.Path:
    """``$EXCAVSIM_CACHE``, else ``$XDG_CACHE_HOME/excavsim``, else ``~/.cache/excavsim``."""
    if env := os.environ.get("EXCAVSIM_CACHE"):
        return pathlib.Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or pathlib.Path.home() / ".cache"
    return pathlib.Path(base) / "excavsim"


def load_or_build(arm: PlanarArm, spec: TableSpec = TableSpec(), *,
                  cache_dir: pathlib.Path | None = None) -> ReachabilityTable:
    """The reachability table for ``arm``, from the disk cache when its key matches, else built and cached.

    A cache file that cannot be read (truncated, other format) is rebuilt and replaced.
    """
    path = (cache_dir or default_cache_dir()) / f"reach_{ReachabilityTable.cache_key(arm, spec)}.npz"
    if path.exists():
        try:
            return ReachabilityTable.load(path, spec)
        except (OSError, ValueError, KeyError):
            pass  # stale or damaged: rebuild below
    table = ReachabilityTable.build(arm, spec)
    try:
        table.save(path)
    except OSError:
        pass  # a read-only cache only costs a rebuild next time
    return table
