"""Geometry for Rerun: MuJoCo geoms as Rerun archetypes, heightfield grids as meshes, colours."""

from __future__ import annotations

import mujoco
import numpy as np
import rerun as rr

SAND_RGB = np.array([194, 170, 120])
OVERDIG_RGB = np.array([220, 40, 30])
MAP_RGB = np.array([150, 175, 205])
FILLED_RGB = np.array([235, 150, 60])
PHASE_NAMES = ("penetrate", "drag", "curl")
PHASE_RGB = ((230, 90, 40), (240, 200, 40), (60, 170, 230))
# Control points of a viridis-like ramp, for the planner's volumes (dark: little soil, yellow: full).
_RAMP = np.array([[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]], float)
# The feasible set is drawn with each grid axis scaled to this length, whatever its unit.
PLAN_AXIS_LENGTH = 2.0


def quat_xyzw(wxyz: np.ndarray) -> np.ndarray:
    """Rerun's (x, y, z, w) quaternions from MuJoCo's (w, x, y, z), shape (..., 4)."""
    return np.roll(np.asarray(wxyz, dtype=np.float32), -1, axis=-1)


def grid_triangles(n_rows: int, n_cols: int) -> np.ndarray:
    """Triangles (2 (n_rows - 1) (n_cols - 1), 3) of a row-major vertex grid, counter-clockwise from +z."""
    r, c = np.meshgrid(np.arange(n_rows - 1), np.arange(n_cols - 1), indexing="ij")
    a = (r * n_cols + c).ravel()
    b, d, e = a + 1, a + n_cols + 1, a + n_cols
    return np.concatenate([np.stack([a, b, d], 1), np.stack([a, d, e], 1)]).astype(np.uint32)


def grid_normals(heights: np.ndarray, cell: float) -> np.ndarray:
    """Unit normals (n_rows * n_cols, 3) of a height grid with rows along y and columns along x."""
    dzdy, dzdx = np.gradient(heights, cell)
    n = np.stack([-dzdx, -dzdy, np.ones_like(heights)], axis=-1).reshape(-1, 3)
    return (n / np.linalg.norm(n, axis=1, keepdims=True)).astype(np.float32)


def ramp_colours(t: np.ndarray) -> np.ndarray:
    """RGB (..., 3) uint8 of values ``t`` in [0, 1] (clipped) on a viridis-like ramp."""
    s = np.clip(np.asarray(t, float), 0.0, 1.0) * (len(_RAMP) - 1)
    i = np.minimum(s.astype(int), len(_RAMP) - 2)
    f = (s - i)[..., None]
    return ((1 - f) * _RAMP[i] + f * _RAMP[i + 1]).astype(np.uint8)


def mesh_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted unit vertex normals (V, 3) of a triangle mesh."""
    v = vertices[faces]
    fn = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    n = np.zeros_like(vertices)
    for k in range(3):
        np.add.at(n, faces[:, k], fn)
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)


def geom_archetype(model: mujoco.MjModel, g: int):
    """A Rerun archetype drawing geom ``g`` in its body's frame, or None for types not drawn."""
    rgba = model.mat_rgba[model.geom_matid[g]] if model.geom_matid[g] >= 0 else model.geom_rgba[g]
    colour = (np.clip(rgba, 0, 1) * 255).astype(np.uint8)
    pos, size, kind = model.geom_pos[g], model.geom_size[g], model.geom_type[g]
    quat = rr.Quaternion(xyzw=quat_xyzw(model.geom_quat[g]))
    solid = rr.components.FillMode.Solid
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        return rr.Boxes3D(half_sizes=[size], centers=[pos], quaternions=[quat], colors=[colour], fill_mode=solid)
    if kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
        return rr.Cylinders3D(lengths=[2 * size[1]], radii=[size[0]], centers=[pos], quaternions=[quat],
                              colors=[colour], fill_mode=solid)
    if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:  # Rerun's capsule runs from its origin along +z
        rot = np.zeros(9)
        mujoco.mju_quat2Mat(rot, model.geom_quat[g])
        start = pos - rot.reshape(3, 3)[:, 2] * size[1]
        return rr.Capsules3D(lengths=[2 * size[1]], radii=[size[0]], translations=[start], quaternions=[quat],
                             colors=[colour], fill_mode=solid)
    if kind in (mujoco.mjtGeom.mjGEOM_SPHERE, mujoco.mjtGeom.mjGEOM_ELLIPSOID):
        half = np.full(3, size[0]) if kind == mujoco.mjtGeom.mjGEOM_SPHERE else size
        return rr.Ellipsoids3D(half_sizes=[half], centers=[pos], quaternions=[quat], colors=[colour],
                               fill_mode=solid)
    if kind == mujoco.mjtGeom.mjGEOM_MESH:
        m = model.geom_dataid[g]
        v0, nv = model.mesh_vertadr[m], model.mesh_vertnum[m]
        f0, nf = model.mesh_faceadr[m], model.mesh_facenum[m]
        rot = np.zeros(9)
        mujoco.mju_quat2Mat(rot, model.geom_quat[g])
        verts = model.mesh_vert[v0:v0 + nv] @ rot.reshape(3, 3).T + pos
        faces = model.mesh_face[f0:f0 + nf]
        return rr.Mesh3D(vertex_positions=verts, triangle_indices=faces, vertex_normals=mesh_normals(verts, faces),
                         albedo_factor=colour)
    return None
