"""Generate the excavator bucket of the T3 model from a few dimensions.

The bucket is the one of a small commercial trenching machine (Singh 1995 §7.1.1):
about 0.30 m wide and 0.02 m^3 struck capacity. Its side profile is a flat blade, a circular arc
into a straight back wall, and an open mouth from the top of the back wall to the cutting edge.

Running this script writes ``models/t3/assets/bucket.stl`` and prints the MJCF fragment (inertial,
collision boxes, profile sites, custom numerics) that ``models/t3/t3.xml`` carries. A test checks
that the committed model still matches these dimensions, so change them here and paste the output.

Frames. The *tip frame* (the ``bucket_tip`` site) has x along the blade from heel to cutting edge,
z normal to the blade pointing into the bucket, y = z cross x. The *bucket body frame* has its origin
at the wrist flange (``ft_mount``) and x along the tool (wrist roll) axis.

Usage: python scripts/make_bucket.py [--write]
"""

from __future__ import annotations

import argparse
import dataclasses
import pathlib

import numpy as np
import trimesh

ASSET = pathlib.Path(__file__).resolve().parents[1] / "models" / "t3" / "assets" / "bucket.stl"


@dataclasses.dataclass(frozen=True)
class BucketDims:
    """Bucket dimensions [m, kg]. Tip-frame coordinates are (x along blade, z into bucket)."""

    inner_width: float = 0.30
    plate_thickness: float = 0.008
    blade_length: float = 0.24  # flat bottom from the cutting edge to the start of the arc
    arc_radius: float = 0.14  # bottom-to-back arc
    back_height: float = 0.38  # top of the back wall above the blade plane
    flange_height: float = 0.42  # wrist flange (bracket) above the blade plane, on the back wall line
    mass: float = 28.0

    @property
    def depth(self) -> float:
        """Distance from cutting edge to the back wall along the blade [m]."""
        return self.blade_length + self.arc_radius


def profile_polyline(d: BucketDims, n_arc: int = 8) -> np.ndarray:
    """Inner cutting profile, tip -> blade -> arc -> back top, in the tip frame.

    Returns:
        (n, 2) array of (x, z) [m]; the first point is the cutting edge (0, 0).
    """
    pts = [(0.0, 0.0), (-d.blade_length, 0.0)]
    cx, cz = -d.blade_length, d.arc_radius
    for a in np.linspace(-np.pi / 2, -np.pi, n_arc + 1)[1:]:
        pts.append((cx + d.arc_radius * np.cos(a), cz + d.arc_radius * np.sin(a)))
    pts.append((-d.depth, d.back_height))
    return np.asarray(pts, dtype=float)


def struck_area(d: BucketDims) -> float:
    """Area enclosed by the profile and the strike line (back top -> cutting edge) [m^2]."""
    # Exact: the rectangle depth x back_height minus the triangle above the strike line, minus the
    # corner the arc cuts off (r^2 - pi r^2 / 4).
    r = d.arc_radius
    return d.depth * d.back_height / 2.0 - (r * r - np.pi * r * r / 4.0)


def struck_capacity(d: BucketDims) -> float:
    """Struck capacity: profile area times inner width [m^3]."""
    return struck_area(d) * d.inner_width


def tip_to_body(d: BucketDims, p_tip: np.ndarray) -> np.ndarray:
    """Map tip-frame points (x, y, z) to the bucket body frame (origin at the flange).

    Tip-frame axes in body coordinates: x_t = (0, 0, -1), y_t = (0, -1, 0), z_t = (-1, 0, 0); the
    flange sits at tip-frame (x, z) = (-depth, flange_height).
    """
    p_tip = np.atleast_2d(p_tip)
    tip_in_body = np.array([d.flange_height, 0.0, -d.depth])
    return tip_in_body + np.stack([-p_tip[:, 2], -p_tip[:, 1], -p_tip[:, 0]], axis=-1)


def _extrude_band(inner: np.ndarray, outer: np.ndarray, y0: float, y1: float) -> trimesh.Trimesh:
    """A closed plate: the strip between two polylines (x, z) extruded from y0 to y1."""
    ring = np.vstack([inner, outer[::-1]])  # closed outline of the band
    n = len(ring)
    verts = np.vstack([np.column_stack([ring[:, 0], np.full(n, y0), ring[:, 1]]),
                       np.column_stack([ring[:, 0], np.full(n, y1), ring[:, 1]])])
    faces = []
    m = len(inner)
    for i in range(m - 1):  # caps as quads between matching inner/outer points
        a, b, c, e = i, i + 1, n - 2 - i, n - 1 - i
        faces += [[a, b, c], [a, c, e], [n + a, n + c, n + b], [n + a, n + e, n + c]]
    for i in range(n):  # sides
        j = (i + 1) % n
        faces += [[j, i, n + i], [j, n + i, n + j]]
    return trimesh.Trimesh(verts, np.asarray(faces), process=True)


def _extrude_convex(poly: np.ndarray, y0: float, y1: float) -> trimesh.Trimesh:
    """A convex polygon (x, z) extruded from y0 to y1."""
    n = len(poly)
    verts = np.vstack([np.column_stack([poly[:, 0], np.full(n, y0), poly[:, 1]]),
                       np.column_stack([poly[:, 0], np.full(n, y1), poly[:, 1]])])
    faces = [[0, i, i + 1] for i in range(1, n - 1)] + [[n, n + i + 1, n + i] for i in range(1, n - 1)]
    for i in range(n):
        j = (i + 1) % n
        faces += [[j, i, n + i], [j, n + i, n + j]]
    return trimesh.Trimesh(verts, np.asarray(faces), process=True)


def _outward_offset(poly: np.ndarray, t: float) -> np.ndarray:
    """Offset an open polyline by t to its outside (away from the bucket's inside)."""
    tang = np.gradient(poly, axis=0)
    tang /= np.linalg.norm(tang, axis=1, keepdims=True)
    # Walking tip -> heel -> back, (t_z, -t_x) points to the inside of the bucket.
    normal_in = np.column_stack([tang[:, 1], -tang[:, 0]])
    return poly - t * normal_in


def bucket_mesh(d: BucketDims) -> trimesh.Trimesh:
    """The visual bucket mesh in the bucket body frame."""
    t, w = d.plate_thickness, d.inner_width
    inner = profile_polyline(d, n_arc=12)
    shell = _extrude_band(inner, _outward_offset(inner, t), -w / 2 - t, w / 2 + t)
    side_l = _extrude_convex(inner, w / 2, w / 2 + t)
    side_r = _extrude_convex(inner, -w / 2 - t, -w / 2)
    bracket = trimesh.creation.box(extents=(0.06, 0.16, d.flange_height - d.back_height + 0.02))
    bracket.apply_translation((-d.depth - t / 2 - 0.03, 0.0, (d.flange_height + d.back_height) / 2 - 0.01))
    parts = []
    for part in (shell, side_l, side_r, bracket):
        if part.volume < 0:  # outward normals, so that the mass properties come out positive
            part.invert()
        v = tip_to_body(d, part.vertices)
        parts.append(trimesh.Trimesh(v, part.faces, process=True))  # a proper rotation: winding kept
    mesh = trimesh.util.concatenate(parts)
    return mesh


def collision_boxes(d: BucketDims) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Box primitives along the bottom and back plates: (pos, xaxis, half_sizes) in the body frame."""
    coarse = profile_polyline(d, n_arc=3)
    out = []
    t, w = d.plate_thickness, d.inner_width
    for a, b in zip(coarse[:-1], coarse[1:]):
        mid = (a + b) / 2
        tang = (b - a) / np.linalg.norm(b - a)
        normal_in = np.array([tang[1], -tang[0]])  # towards the inside of the bucket
        centre = mid - normal_in * t / 2  # the box lies on the plate, outside the inner profile
        half = np.array([np.linalg.norm(b - a) / 2, w / 2 + t, t / 2 + 0.004])
        pos = tip_to_body(d, np.array([[centre[0], 0.0, centre[1]]]))[0]
        xaxis = tip_to_body(d, np.array([[tang[0], 0.0, tang[1]]]))[0] - tip_to_body(d, np.zeros((1, 3)))[0]
        out.append((pos, xaxis, half))
    return out


def profile_sites(d: BucketDims) -> np.ndarray:
    """Points outlining the cutting profile (tip first), in the bucket body frame, shape (n, 3)."""
    pts = profile_polyline(d, n_arc=4)
    return tip_to_body(d, np.column_stack([pts[:, 0], np.zeros(len(pts)), pts[:, 1]]))


def inertial(d: BucketDims, mesh: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray]:
    """Centre of mass and full inertia (xx yy zz xy xz yz) of the plate mesh at the bucket mass."""
    scale = d.mass / mesh.volume
    com = mesh.center_mass
    inertia = mesh.moment_inertia * scale  # about the centre of mass, body axes
    return com, np.array([inertia[0, 0], inertia[1, 1], inertia[2, 2],
                          inertia[0, 1], inertia[0, 2], inertia[1, 2]])


def fmt(v) -> str:
    return " ".join(f"{x:.6g}" for x in np.ravel(v))


def mjcf_fragment(d: BucketDims) -> str:
    """The MJCF lines for the bucket body that t3.xml carries."""
    mesh = bucket_mesh(d)
    com, inert = inertial(d, mesh)
    lines = [f'<inertial pos="{fmt(com)}" mass="{d.mass:g}" fullinertia="{fmt(inert)}"/>']
    for i, (pos, xaxis, half) in enumerate(collision_boxes(d)):
        yaxis = np.array([0.0, 1.0, 0.0])
        lines.append(f'<geom name="bucket_collision_{i}" class="collision" type="box" size="{fmt(half)}" '
                     f'pos="{fmt(pos)}" xyaxes="{fmt(xaxis)} {fmt(yaxis)}"/>')
    for i, p in enumerate(profile_sites(d)):
        lines.append(f'<site name="bucket_profile_{i}" class="profile" pos="{fmt(p)}"/>')
    tip = tip_to_body(d, np.zeros((1, 3)))[0]
    lines.append(f'<site name="bucket_tip" class="tip" pos="{fmt(tip)}" xyaxes="0 0 -1 0 -1 0"/>')
    lines.append(f'<numeric name="bucket_width" data="{d.inner_width:g}"/>')
    lines.append(f'<numeric name="bucket_capacity" data="{struck_capacity(d):.6g}"/>')
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help=f"write {ASSET.name} into models/t3/assets")
    args = parser.parse_args()
    d = BucketDims()
    mesh = bucket_mesh(d)
    print(f"struck area {struck_area(d):.4f} m^2, capacity {struck_capacity(d):.4f} m^3, "
          f"mesh {len(mesh.vertices)} vertices, {len(mesh.faces)} faces")
    print(mjcf_fragment(d))
    if args.write:
        mesh.export(ASSET)
        print(f"wrote {ASSET}")


if __name__ == "__main__":
    main()
