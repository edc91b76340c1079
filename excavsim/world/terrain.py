"""The soil surface: a heightfield over the box in metres, the single source of truth.

:class:`SoilGrid` holds ``heights[row, col]`` [m above the box floor] at the samples of the MuJoCo
``soil`` hfield: ``row`` runs along world y and ``col`` along world x, sample (row, col) sits at
``(x0 + col * cell, y0 + row * cell)``, the layout of MuJoCo's ``hfield_data`` (checked with
``mj_ray`` in the tests). Each sample stands for a column of area ``cell**2``, so the soil volume in
the box is ``cell**2 * heights.sum()``; every change made here moves volume between columns, the
bucket and the spoil account, never creating or losing any (up to floating-point round-off).

The MuJoCo hfield is a view for rays and rendering only: :meth:`SoilGrid.write_hfield` normalizes
heights by the hfield's elevation size into [0, 1] (clipping at the top; the 1.4 m range leaves
0.4 m of headroom above the 1 m walls) and copies the changed window.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from excavsim import constants
from excavsim.errors import ModelError
from excavsim.readouts import element_id


@dataclasses.dataclass
class SoilGrid:
    """Heights of the soil surface over the box [m], with the geometry to map them to the world.

    Attributes:
        heights: (n_rows, n_cols) float64, modified in place by cutting, deposits and settlement.
        x0, y0: world position of sample (0, 0) [m].
        cell: sample spacing [m].
        z0: world height of the box floor (height 0) [m].
        elevation: the hfield's elevation range [m] (heights map to hfield data as h / elevation).
    """

    heights: np.ndarray
    x0: float
    y0: float
    cell: float
    z0: float = 0.0
    elevation: float = 1.4
    _dirty: list[int] | None = dataclasses.field(default=None, repr=False)

    @classmethod
    def from_model(cls, model: mujoco.MjModel, fill_height_m: float) -> SoilGrid:
        """A flat fill at ``fill_height_m`` over the hfield of ``model`` (its soil geom's placement)."""
        hid = element_id(model, "hfield", constants.SOIL_HFIELD)
        gid = element_id(model, "geom", constants.SOIL_GEOM)
        data = mujoco.MjData(model)
        mujoco.mj_kinematics(model, data)
        sx, sy, elevation, _ = model.hfield_size[hid]
        nrow, ncol = int(model.hfield_nrow[hid]), int(model.hfield_ncol[hid])
        cell = 2 * sx / (ncol - 1)
        if abs(2 * sy / (nrow - 1) - cell) > 1e-12:
            raise ModelError("the soil hfield must have square cells")
        if not 0 <= fill_height_m <= elevation:
            raise ModelError(f"fill height {fill_height_m} m is outside the hfield's range [0, {elevation}] m")
        centre = data.geom_xpos[gid]
        heights = np.full((nrow, ncol), float(fill_height_m))
        return cls(heights, float(centre[0] - sx), float(centre[1] - sy), float(cell), float(centre[2]),
                   float(elevation))

    # -- geometry -------------------------------------------------------------------------------
    @property
    def shape(self) -> tuple[int, int]:
        return self.heights.shape

    @property
    def cell_area(self) -> float:
        return self.cell * self.cell

    @property
    def x1(self) -> float:
        """World x of the last column [m]."""
        return self.x0 + (self.heights.shape[1] - 1) * self.cell

    @property
    def y1(self) -> float:
        """World y of the last row [m]."""
        return self.y0 + (self.heights.shape[0] - 1) * self.cell

    def volume(self) -> float:
        """Soil volume in the box [m^3] (column model: cell^2 per sample)."""
        return float(self.heights.sum()) * self.cell_area

    def xy(self, rows: np.ndarray, cols: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World (x, y) of samples."""
        return self.x0 + np.asarray(cols) * self.cell, self.y0 + np.asarray(rows) * self.cell

    def index(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Nearest sample (row, col) of world points and whether they lie over the grid."""
        c = np.rint((np.asarray(x, float) - self.x0) / self.cell).astype(np.int64)
        r = np.rint((np.asarray(y, float) - self.y0) / self.cell).astype(np.int64)
        inside = (r >= 0) & (r < self.heights.shape[0]) & (c >= 0) & (c < self.heights.shape[1])
        return r, c, inside

    def surface_z(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """World height of the surface below points, bilinear between samples; -inf off the grid."""
        x = np.asarray(x, float)
        y = np.asarray(y, float)
        u = (x - self.x0) / self.cell
        v = (y - self.y0) / self.cell
        nr, nc = self.heights.shape
        inside = (u >= 0) & (u <= nc - 1) & (v >= 0) & (v <= nr - 1)
        uc = np.clip(u, 0, nc - 1 - 1e-9)
        vc = np.clip(v, 0, nr - 1 - 1e-9)
        c0 = uc.astype(np.int64)
        r0 = vc.astype(np.int64)
        fu = uc - c0
        fv = vc - r0
        h = self.heights
        z = ((1 - fu) * (1 - fv) * h[r0, c0] + fu * (1 - fv) * h[r0, c0 + 1]
             + (1 - fu) * fv * h[r0 + 1, c0] + fu * fv * h[r0 + 1, c0 + 1])
        return np.where(inside, z + self.z0, -np.inf)

    # -- changes --------------------------------------------------------------------------------
    def mark(self, r0: int, r1: int, c0: int, c1: int) -> None:
        """Record that rows [r0, r1) x cols [c0, c1) changed (for settlement and the hfield write)."""
        nr, nc = self.heights.shape
        r0, r1, c0, c1 = max(0, r0), min(nr, r1), max(0, c0), min(nc, c1)
        if r0 >= r1 or c0 >= c1:
            return
        if self._dirty is None:
            self._dirty = [r0, r1, c0, c1]
        else:
            d = self._dirty
            self._dirty = [min(d[0], r0), max(d[1], r1), min(d[2], c0), max(d[3], c1)]

    def take_dirty(self) -> tuple[int, int, int, int] | None:
        """The window changed since the last call (half-open rows, cols), and forget it."""
        d, self._dirty = self._dirty, None
        return None if d is None else (d[0], d[1], d[2], d[3])

    def peek_dirty(self) -> tuple[int, int, int, int] | None:
        """The window changed since the last :meth:`take_dirty`, without forgetting it."""
        return None if self._dirty is None else tuple(self._dirty)  # type: ignore[return-value]

    def deposit(self, x: np.ndarray, y: np.ndarray, volumes: np.ndarray, radius_m: float = 0.0) -> float:
        """Drop soil volumes at world points, spread evenly over the samples within ``radius_m``.

        Returns:
            The part of the volume that fell outside the grid [m^3] (it belongs to the spoil
            account); what lands is added exactly, so box volume + returned = sum(volumes).
        """
        x = np.atleast_1d(np.asarray(x, float))
        y = np.atleast_1d(np.asarray(y, float))
        volumes = np.broadcast_to(np.asarray(volumes, float), x.shape)
        k = max(0, int(np.floor(radius_m / self.cell)))
        di, dj = np.mgrid[-k:k + 1, -k:k + 1]
        disc = (di * di + dj * dj) * self.cell ** 2 <= radius_m ** 2 + 1e-12
        di, dj = di[disc], dj[disc]
        lost = 0.0
        r, c, _ = self.index(x, y)
        nr, nc = self.heights.shape
        for ri, ci, v in zip(r, c, volumes):
            if v <= 0:
                continue
            rr, cc = ri + di, ci + dj
            ok = (rr >= 0) & (rr < nr) & (cc >= 0) & (cc < nc)
            n_in = int(ok.sum())
            if n_in == 0:
                lost += v
                continue
            share = v / len(di)
            lost += share * (len(di) - n_in)
            np.add.at(self.heights, (rr[ok], cc[ok]), share / self.cell_area)
            self.mark(int(rr[ok].min()), int(rr[ok].max()) + 1, int(cc[ok].min()), int(cc[ok].max()) + 1)
        return lost

    # -- MuJoCo view ----------------------------------------------------------------------------
    def hfield_view(self, model: mujoco.MjModel) -> np.ndarray:
        """The model's soil hfield data as a writable (n_rows, n_cols) view."""
        hid = element_id(model, "hfield", constants.SOIL_HFIELD)
        nrow, ncol = int(model.hfield_nrow[hid]), int(model.hfield_ncol[hid])
        if (nrow, ncol) != self.heights.shape:
            raise ModelError(f"hfield is {nrow}x{ncol}, the soil grid {self.heights.shape}")
        return model.hfield_data[model.hfield_adr[hid]:model.hfield_adr[hid] + nrow * ncol].reshape(nrow, ncol)

    def write_hfield(self, model: mujoco.MjModel | np.ndarray,
                     window: tuple[int, int, int, int] | None = None) -> None:
        """Copy heights (all, or a window of rows/cols) into the hfield, normalized to [0, 1].

        Args:
            model: the model, or a view from :meth:`hfield_view` (faster when called every step).
        """
        view = model if isinstance(model, np.ndarray) else self.hfield_view(model)
        nrow, ncol = view.shape
        r0, r1, c0, c1 = window or (0, nrow, 0, ncol)
        np.clip(self.heights[r0:r1, c0:c1] / self.elevation, 0.0, 1.0, out=view[r0:r1, c0:c1])
