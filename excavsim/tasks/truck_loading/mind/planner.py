"""Where to dig next and where to dump next in the truck, from the scans (Rowe 1997 §6.1): numpy only.

Rowe's system had "software modules which use perceptual data for ... determining where to dig next based
on the current terrain conditions, determining where to dump next based on how the soil is resting in the
truck" (§6.1) without saying how; the rules here are **assumed**, the simplest that use the scans:

* :func:`choose_dig`: on the pit's elevation map, each candidate dig (a swing angle and a start radius,
  the drag running ``drag_m`` towards the machine) is scored by the soil it would cut, the map's height
  above the cut's floor over the bucket's width along the drag (medians over the band: a scanner's
  outlier does not make a face), less a price per radian of swing from the truck; the best wins. As the
  passes lower one place, the next dig moves to where the face stands highest.
* :func:`bed_map`: the bed scanner's points binned into the bed's cells (the median height per cell;
  cells no ray saw take their neighbours' mean, an empty bed the floor).
* :func:`choose_dump`: the bed's cells smoothed over the bucket's footprint; the lowest region along the
  bed's centre line is where the next load goes (so the load spreads evenly along the truck; across it the
  pour's own sweep spreads it), ties to the bed's centre.
* :func:`deposit_centre`: where a pass's soil went, the centre of the difference of two bed maps (the
  mind's measure of the placement, Fig. 11's polar coordinates about the swing axis).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np


@dataclasses.dataclass(frozen=True)
class BedGeometry:
    """The truck's bed as the mind knows it (assumed known: Rowe's system located the truck with its scanner).

    Attributes: x_m, y_m: the bed's centre [m]; yaw: heading [rad]; length_m, width_m: inside [m];
    floor_m: floor height [m]; cell_m: the map's cell [m].
    """

    x_m: float
    y_m: float
    yaw: float
    length_m: float
    width_m: float
    floor_m: float
    cell_m: float = 0.2

    @property
    def shape(self) -> tuple[int, int]:
        return int(round(self.width_m / self.cell_m)), int(round(self.length_m / self.cell_m))

    def to_local(self, x, y):
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        dx, dy = np.asarray(x, float) - self.x_m, np.asarray(y, float) - self.y_m
        return c * dx + s * dy, -s * dx + c * dy

    def to_world(self, u, v):
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return self.x_m + c * np.asarray(u, float) - s * np.asarray(v, float), \
            self.y_m + s * np.asarray(u, float) + c * np.asarray(v, float)

    def centres(self) -> tuple[np.ndarray, np.ndarray]:
        """Cell centres in the bed's frame: u (ncols,), v (nrows,) [m]."""
        nr, nc = self.shape
        return (-0.5 * self.length_m + (np.arange(nc) + 0.5) * self.cell_m,
                -0.5 * self.width_m + (np.arange(nr) + 0.5) * self.cell_m)


def bed_map(points: np.ndarray, bed: BedGeometry) -> np.ndarray:
    """The soil's depth on the bed's floor per cell (nrows, ncols) [m] from scanned points (n, 3) (module
    docstring). Points on the sides' tops (outside the inside) are left out."""
    nr, nc = bed.shape
    u, v = bed.to_local(points[:, 0], points[:, 1])
    col = np.floor((u + 0.5 * bed.length_m) / bed.cell_m).astype(int)
    row = np.floor((v + 0.5 * bed.width_m) / bed.cell_m).astype(int)
    ok = (col >= 0) & (col < nc) & (row >= 0) & (row < nr)
    depth = np.full((nr, nc), np.nan)
    flat = row[ok] * nc + col[ok]
    z = points[ok, 2] - bed.floor_m
    order = np.argsort(flat, kind="stable")
    flat, z = flat[order], z[order]
    cells, first = np.unique(flat, return_index=True)
    for k, cell in enumerate(cells):
        end = first[k + 1] if k + 1 < len(first) else len(flat)
        depth.flat[cell] = float(np.median(z[first[k]:end]))
    for _ in range(max(nr, nc)):  # unseen cells: the mean of their seen neighbours, repeated
        miss = np.isnan(depth)
        if not miss.any():
            break
        pad = np.pad(depth, 1, constant_values=np.nan)
        stack = np.stack([pad[i:i + nr, j:j + nc] for i in range(3) for j in range(3)])
        seen = np.isfinite(stack)
        mean = np.where(seen.any(axis=0), np.where(seen, stack, 0.0).sum(axis=0) / np.maximum(seen.sum(axis=0), 1),
                        np.nan)
        fill = miss & np.isfinite(mean)
        if not fill.any():
            depth[miss] = 0.0
            break
        depth[fill] = mean[fill]
    return np.clip(depth, 0.0, None)


def map_volume(depth: np.ndarray, bed: BedGeometry) -> float:
    """The soil in the bed by the map [m^3]."""
    return float(depth.sum() * bed.cell_m ** 2)


def choose_dump(depth: np.ndarray, bed: BedGeometry, *, footprint_m: float = 1.2, margin_m: float = 0.7,
                across_m: float = 0.1) -> tuple[float, float]:
    """Where the next load goes (module docstring): world (x, y) [m]. Candidates keep ``margin_m`` from the
    bed's ends and stay within ``across_m`` of its centre line: the opening bucket pours along a sweep of
    about a metre across the bed (the swing's radius; measured) over a disc of its half-width, so only the
    centre line of a 2.3 m bed keeps the whole pour inside. The score is the mean depth over a square of
    ``footprint_m``, plus a hundredth of the distance from the centre (ties to the centre)."""
    nr, nc = depth.shape
    k = max(1, int(round(footprint_m / bed.cell_m / 2)))
    pad = np.pad(depth, k, mode="edge")
    win = sum(pad[i:i + nr, j:j + nc] for i in range(2 * k + 1) for j in range(2 * k + 1)) / (2 * k + 1) ** 2
    u, v = bed.centres()
    uu, vv = np.meshgrid(u, v)
    ok = (np.abs(uu) <= 0.5 * bed.length_m - margin_m) & (np.abs(vv) <= across_m + 1e-9)
    if not ok.any():
        ok = np.abs(vv) <= np.abs(vv).min() + 1e-9
    score = np.where(ok, win + 0.01 * np.hypot(uu, vv), np.inf)
    i, j = np.unravel_index(int(np.argmin(score)), score.shape)
    x, y = bed.to_world(uu[i, j], vv[i, j])
    return float(x), float(y)


def deposit_centre(before: np.ndarray, after: np.ndarray, bed: BedGeometry) -> tuple[float, float, float]:
    """The centre (world x, y) [m] of what a pass added to the bed (``after - before``, positive part) and
    its volume [m^3]; the bed's centre when nothing was added."""
    d = np.clip(after - before, 0.0, None)
    total = d.sum()
    if total <= 0:
        return bed.x_m, bed.y_m, 0.0
    u, v = bed.centres()
    uu, vv = np.meshgrid(u, v)
    x, y = bed.to_world(float((d * uu).sum() / total), float((d * vv).sum() / total))
    return float(x), float(y), float(total * bed.cell_m ** 2)


def load_offset(depth: np.ndarray, bed: BedGeometry) -> tuple[float, float]:
    """The load's centre in the bed's frame by the map (u along, v across) [m] (how evenly it is loaded)."""
    total = depth.sum()
    if total <= 0:
        return 0.0, 0.0
    u, v = bed.centres()
    return float((depth.sum(axis=0) * u).sum() / total), float((depth.sum(axis=1) * v).sum() / total)


@dataclasses.dataclass(frozen=True)
class DigChoice:
    """A dig: swing angle [rad], start radius [m], and the soil the map shows above its floor [m^3]."""

    swing: float
    start_r: float
    soil_m3: float


def choose_dig(height_at, swings: np.ndarray, radii: np.ndarray, *, drag_m: float, depth_m: float,
               width_m: float, floor_z: float, truck_swing: float, per_rad_m3: float = 0.05) -> DigChoice:
    """The next dig on the pit's map (module docstring). ``height_at(x, y)`` is the map's height; the cut's
    floor is ``depth_m`` below the surface where the drag starts, never below ``floor_z``."""
    best = None
    along = np.linspace(0.0, drag_m, 13)
    across = np.linspace(-0.5 * width_m, 0.5 * width_m, 5)
    for sw in swings:
        c, s = math.cos(sw), math.sin(sw)
        for r0 in radii:
            r = r0 - along
            xx = (r[:, None] * c - across[None, :] * s)
            yy = (r[:, None] * s + across[None, :] * c)
            z = np.median(np.asarray(height_at(xx.ravel(), yy.ravel())).reshape(xx.shape), axis=1)
            floor = max(float(np.median(z[:3])) - depth_m, floor_z)
            soil = float(np.clip(z - floor, 0.0, depth_m).sum() * (along[1] - along[0]) * width_m)
            score = soil - per_rad_m3 * abs(truck_swing - sw)
            if best is None or score > best[0]:
                best = (score, DigChoice(float(sw), float(r0), soil))
    return best[1]
