"""The trench goal's part of the batched environment's compiled path (:mod:`excavsim.envs.batched`).

:class:`TrenchBatch` is :class:`~excavsim.tasks.trench.envs.joint.JointTrench`'s ``BATCH``: what the trench
goal computes for N copies of the joint-level world at once, with the numbers each copy's goal gives alone
(tests/envs/test_rl.py checks the batched environment against N single ones to the bit):

* the true trench of all copies measured in one gather (:func:`gather_cells`) and one numpy pass, where the
  copies share the footprint (:class:`~excavsim.tasks.trench.envs.core.TrueTrench.measure`'s operations on
  the rows of stacked arrays);
* the height patches of all copies in one compiled pass (:func:`patch_kernel`) on their scanned maps
  stacked (:meth:`PatchLayout.patches <excavsim.tasks.trench.envs.joint.PatchLayout.patches>`'s arithmetic,
  element by element), beside the tips and the time left.
"""

from __future__ import annotations

import math
from typing import Any

import numba
import numpy as np

@numba.njit(cache=True)
def gather_cells(heights, rows, cols, out):
    """``out[i, j] = heights[i][rows[j], cols[j]]``: the footprint's cells of every copy's true terrain."""
    for i in range(len(heights)):
        h = heights[i]
        for j in range(rows.shape[0]):
            out[i, j] = h[rows[j], cols[j]]


@numba.njit(cache=True, inline="always")
def _bilinear(h, x, y, x0, y0, cell, ny, nx):
    """:meth:`PatchLayout.heights_at <excavsim.tasks.trench.envs.joint.PatchLayout.heights_at>` at one point
    of one map, the same operations in the same order."""
    u = (x - x0) / cell - 0.5
    u = min(max(u, 0.0), nx - 1.0)
    v = (y - y0) / cell - 0.5
    v = min(max(v, 0.0), ny - 1.0)
    c0 = min(np.int64(u), nx - 2)
    r0 = min(np.int64(v), ny - 2)
    fu, fv = u - c0, v - r0
    return ((1 - fu) * (1 - fv) * h[r0, c0] + fu * (1 - fv) * h[r0, c0 + 1]
            + (1 - fu) * fv * h[r0 + 1, c0] + fu * fv * h[r0 + 1, c0 + 1])


@numba.njit(cache=True)
def patch_kernel(heights, tips, off_x, off_y, grid, goal, terrain, goal_out, depth, inside):
    """:meth:`PatchLayout.patches <excavsim.tasks.trench.envs.joint.PatchLayout.patches>` of every copy in
    one compiled pass, element by element with the same arithmetic (so the same numbers, to the bit).

    Args:
        heights: (N, ny, nx) the copies' maps; tips: (N, 3) their tips [m]; off_x, off_y: (P, P) offsets [m].
        grid: (x0, y0, cell) of the maps; goal: (cos waist, sin waist, half width, near x, far x,
            surface z, surface z - depth, tan near wall, tan far wall).
        terrain, goal_out: (N, P, P) written; depth: (N,) written; inside: (N,) bool written.
    """
    x0, y0, cell = grid[0], grid[1], grid[2]
    cw, sw, hw, near, far, z_ref, z_bottom, tan_near, tan_far = (goal[0], goal[1], goal[2], goal[3], goal[4],
                                                                 goal[5], goal[6], goal[7], goal[8])
    ny, nx = heights.shape[1], heights.shape[2]
    for n in range(heights.shape[0]):
        h = heights[n]
        tx, ty, tz = tips[n, 0], tips[n, 1], tips[n, 2]
        for a in range(off_x.shape[0]):
            for b in range(off_x.shape[1]):
                px, py = tx + off_x[a, b], ty + off_y[a, b]
                terrain[n, a, b] = _bilinear(h, px, py, x0, y0, cell, ny, nx) - tz
                radial = px * cw + py * sw
                lateral = -px * sw + py * cw
                z = z_ref
                if abs(lateral) <= hw and radial >= near and radial <= far:
                    z_near = z_ref - (radial - near) * tan_near
                    z_far = z_ref - (far - radial) * tan_far
                    z = max(max(z_near, z_far), z_bottom)
                goal_out[n, a, b] = z - tz
        t_radial = tx * cw + ty * sw
        t_lateral = -tx * sw + ty * cw
        inside[n] = abs(t_lateral) <= hw and t_radial >= near and t_radial <= far
        depth[n] = _bilinear(h, tx, ty, x0, y0, cell, ny, nx) - tz


def _layout_constants(layout) -> tuple[np.ndarray, np.ndarray]:
    """The grid and goal numbers :func:`patch_kernel` takes, computed as :class:`PatchLayout` and
    :func:`~excavsim.handoff.goal.goal_profile` compute them."""
    g = layout.goal
    grid = np.array([layout.x0, layout.y0, layout.cell], dtype=np.float64)
    goal = np.array([layout.cw, layout.sw, layout.half_width, g.near_x_m, g.far_x_m, g.surface_z_m,
                     g.surface_z_m - g.depth_m, math.tan(math.radians(g.near_wall_deg)),
                     math.tan(math.radians(g.far_wall_deg))], dtype=np.float64)
    return grid, goal


class TrenchBatch:
    """The trench goal of the copies ``cores`` (each a :class:`~excavsim.envs.joint_core.JointCore` whose goal is a
    :class:`~excavsim.tasks.trench.envs.joint.JointTrench`), computed together (the module docstring).

    Attributes:
        shared: whether the copies' true-trench measures read the same cells against the same goal (then
            :meth:`measure` takes them together; else each copy measures itself).
    """

    def __init__(self, cores):
        self.cores = cores
        n = len(cores)
        self._maps: np.ndarray | None = None  # (N, ny, nx) the copies' scanned maps
        self._map_of: list[Any] = [None] * n
        self._h0: np.ndarray | None = None  # (N, cells) the footprint's first heights, when the copies share it
        self._cells: np.ndarray | None = None
        self._layout = None
        self.shared = False

    def attach(self, i: int) -> None:
        """Copy ``i`` was reset: its scanned map and its true trench's first heights."""
        n = len(self.cores)
        goal = self.cores[i].goal
        emap = goal.emap
        if self._maps is None or self._maps.shape[1:] != emap.heights.shape:
            self._maps = np.zeros((n,) + emap.heights.shape)
        self._maps[i] = emap.heights
        self._map_of[i] = emap
        truth, first = goal.truth, self.cores[0].goal.truth
        if self._h0 is None or self._h0.shape[1] != len(truth.h0):
            self._h0 = np.zeros((n, len(truth.h0)))
            self._cells = np.zeros_like(self._h0)
        self._h0[i] = truth.h0
        self.shared = all(_same_footprint(c.goal.truth, first) for c in self.cores if hasattr(c.goal, "truth"))

    def reset_info(self, i: int) -> dict[str, Any]:
        """Copy ``i``'s info at its reset: the clock and the first scan's done test."""
        goal = self.cores[i].goal
        return {"time_s": 0.0, "map_removed_fraction": goal._frac, "map_done": bool(goal._done)}

    def measure(self, heights) -> list[tuple[float, float]] | None:
        """Every copy's :meth:`TrueTrench.measure <excavsim.tasks.trench.envs.core.TrueTrench.measure>` at once
        from their true terrains ``heights`` (the same numbers: the same operations on the rows of stacked
        arrays), or None when the copies' footprints differ (then each copy measures itself)."""
        if not self.shared:
            return None
        first = self.cores[0].goal.truth
        gather_cells(heights, first.idx[0], first.idx[1], self._cells)
        removed = np.clip(self._h0 - np.maximum(self._cells, first.z_goal), 0, None).sum(axis=1) * first.cell_area
        over = np.clip(first.z_goal - self._cells, 0, None).sum(axis=1) * first.cell_area
        return list(zip(removed.tolist(), over.tolist()))

    def accounted(self, i: int) -> None:
        """Copy ``i`` has accounted its step: its map, if the goal rescanned."""
        emap = self.cores[i].goal.emap
        if emap is not self._map_of[i]:  # rescanned
            self._maps[i] = emap.heights
            self._map_of[i] = emap

    def observe(self, which: np.ndarray, readings: list[Any], out: dict[str, np.ndarray]) -> None:
        """The trench goal's entries (``tip``, ``patch``, ``time_left``) of copies ``which`` into ``out``, and
        each copy's tip depth for its shaping."""
        n = len(self.cores)
        core0 = self.cores[0]
        p = core0.goal.patch_size
        tips = np.zeros((n, 3))
        tip4 = np.zeros((n, 4))
        time_left = [0.0] * n
        for i in np.flatnonzero(which).tolist():  # gathered in float64, cast to float32 once per field
            core = self.cores[i]
            tip, pitch = core.goal.tip(readings[i])
            tips[i] = tip
            tip4[i] = (tip[0], tip[1], tip[2], pitch)
            time_left[i] = max(core.max_time_s - core.goal.elapsed(), 0.0)
        out["tip"][:] = tip4
        out["time_left"][:, 0] = time_left
        layout = core0.goal.layout
        if self._layout is not layout:
            self._layout, (self._grid, self._goal) = layout, _layout_constants(layout)
            self._terrain, self._goal_patch = np.zeros((n, p, p)), np.zeros((n, p, p))
            self._depth, self._inside = np.zeros(n), np.zeros(n, dtype=np.bool_)
        patch_kernel(self._maps, tips, layout.off_x, layout.off_y, self._grid, self._goal, self._terrain,
                     self._goal_patch, self._depth, self._inside)
        depth, inside = self._depth, self._inside
        out["patch"][:, 0] = self._terrain
        out["patch"][:, 1] = self._goal_patch
        for i in np.flatnonzero(which):
            self.cores[i].goal._tip_depth, self.cores[i].goal._tip_inside = float(depth[i]), bool(inside[i])


def _same_footprint(a, b) -> bool:
    """Whether two copies' true-trench measures read the same cells against the same goal."""
    return (a.cell_area == b.cell_area and a.idx[0].shape == b.idx[0].shape and np.array_equal(a.idx[0], b.idx[0])
            and np.array_equal(a.idx[1], b.idx[1]) and np.array_equal(a.z_goal, b.z_goal))
