"""What the scanner hands to the map builder, and the map the planner reads: plain numpy values.

:class:`ScanGeometry` is what the robot knows of its scanner and :class:`RangeImage` what one scan
returns (the simulated scanner, :class:`~excavsim.world.scanner.LaserScanner`, reads the true
terrain and belongs to the world); :class:`ElevationMap` is the robot's belief of the terrain,
built by :func:`~excavsim.sensing.elevation.build_map` (Singh 1995 §7.1.2).
"""

from __future__ import annotations

import dataclasses
import pathlib

import numpy as np

from excavsim.errors import DataFileError, shorten


@dataclasses.dataclass(frozen=True)
class ScanGeometry:
    """What the robot knows about its scanner and the box (surveyed, §7.1.2).

    Attributes:
        origin: (3,) scanner position, world [m].
        directions: (n_el, n_az, 3) unit ray directions of the range image, world.
        target_directions: (n_targets, k, 3) rays aimed at points on each surveyed target plate.
        target_ranges: (n_targets, k) surveyed ranges along those rays [m].
        area: (x0, x1, y0, y1) the soil area inside the walls, world [m].
        wall_top_z: height of the walls' tops [m].
        wall_thickness_m: thickness of the walls, whose tops surround the area [m].
    """

    origin: np.ndarray
    directions: np.ndarray
    target_directions: np.ndarray
    target_ranges: np.ndarray
    area: tuple[float, float, float, float]
    wall_top_z: float
    wall_thickness_m: float = 0.05

    @property
    def image_shape(self) -> tuple[int, int]:
        return self.directions.shape[:2]


@dataclasses.dataclass(frozen=True)
class RangeImage:
    """One scan: ranges along the image rays and the target rays [m]; NaN where there was no return.

    ``reflectance`` is the brightness of each image pixel (0-1, Fig. 96's reflectance image) when the
    scanner returns one, else None.
    """

    time: float
    ranges: np.ndarray
    target_ranges: np.ndarray
    reflectance: np.ndarray | None = None


@dataclasses.dataclass(frozen=True)
class ElevationMap:
    """A grid of soil elevations over the box, as the robot believes it to be.

    Attributes:
        x0, y0: world position of the corner of cell (0, 0) [m]; cell (i, j) spans
            ``x0 + j * cell ... x0 + (j + 1) * cell`` and likewise in y (rows along y).
        cell: cell size [m].
        heights: (ny, nx) elevation of each cell [m, world z].
        observed: (ny, nx) True where scan points fell in the cell; the rest were filled.
        time: simulation time of the last scan used [s].
    """

    x0: float
    y0: float
    cell: float
    heights: np.ndarray
    observed: np.ndarray
    time: float

    @property
    def shape(self) -> tuple[int, int]:
        return self.heights.shape

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(x0, x1, y0, y1): the area the map covers, the soil inside the box's walls [m]."""
        ny, nx = self.heights.shape
        return self.x0, self.x0 + nx * self.cell, self.y0, self.y0 + ny * self.cell

    def centres(self) -> tuple[np.ndarray, np.ndarray]:
        """World x (nx,) and y (ny,) of the cell centres."""
        ny, nx = self.heights.shape
        return self.x0 + (np.arange(nx) + 0.5) * self.cell, self.y0 + (np.arange(ny) + 0.5) * self.cell

    def height_at(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Elevation at world points, bilinear between cell centres (clamped at the edges)."""
        ny, nx = self.heights.shape
        u = np.clip((np.asarray(x, float) - self.x0) / self.cell - 0.5, 0, nx - 1)
        v = np.clip((np.asarray(y, float) - self.y0) / self.cell - 0.5, 0, ny - 1)
        c0 = np.minimum(u.astype(np.int64), nx - 2)
        r0 = np.minimum(v.astype(np.int64), ny - 2)
        fu, fv = u - c0, v - r0
        h = self.heights
        return ((1 - fu) * (1 - fv) * h[r0, c0] + fu * (1 - fv) * h[r0, c0 + 1]
                + (1 - fu) * fv * h[r0 + 1, c0] + fu * fv * h[r0 + 1, c0 + 1])

    def save(self, path: str | pathlib.Path) -> None:
        """Write the map to an ``.npz`` file."""
        np.savez_compressed(path, x0=self.x0, y0=self.y0, cell=self.cell, heights=self.heights,
                            observed=self.observed, time=self.time)

    @classmethod
    def load(cls, path: str | pathlib.Path) -> ElevationMap:
        """Read a map written by :meth:`save`.

        Raises:
            DataFileError: the file is missing, not an ``.npz`` archive, or lacks a field or has one of
                the wrong shape (the message names the file and the field).
        """
        fields = ("x0", "y0", "cell", "heights", "observed", "time")
        try:
            with np.load(path, allow_pickle=False) as f:
                missing = [k for k in fields if k not in f.files]
                if missing:
                    raise DataFileError(f"{path}: not an elevation map written by excavsim: missing "
                                        f"{', '.join(missing)} (a map holds {', '.join(fields)})")
                raw = {k: np.asarray(f[k]) for k in fields}
            scalars = {k: float(raw[k]) for k in ("x0", "y0", "cell", "time")}
            heights, observed = raw["heights"].astype(float), raw["observed"].astype(bool)
        except DataFileError:
            raise
        except Exception as exc:  # numpy's and zipfile's errors for a garbled or truncated file
            raise DataFileError(f"{path}: not an elevation map written by excavsim ({type(exc).__name__}: "
                                f"{shorten(exc)})") from None
        if not all(np.isfinite(list(scalars.values()))) or scalars["cell"] <= 0:
            raise DataFileError(f"{path}: x0, y0, cell and time must be finite and cell > 0; given {scalars}")
        if heights.ndim != 2 or min(heights.shape) < 2 or observed.shape != heights.shape:
            raise DataFileError(f"{path}: heights {heights.shape} and observed {observed.shape} must be one grid "
                                "of at least 2 x 2 cells")
        return cls(scalars["x0"], scalars["y0"], scalars["cell"], heights, observed, scalars["time"])
