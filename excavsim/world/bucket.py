"""The bucket as the soil model sees it: its cutting profile, sampled, in the bucket body frame.

The profile comes from the ``bucket_profile_*`` sites of the model (cutting edge first, then the flat
blade, the arc and the back wall up to its top), extruded across the bucket's inner width (the body
y axis). The interior is the area between the profile and the strike line from the top of the back
wall to the cutting edge; its centroid is where the load's weight acts, and the strike line's
outward normal is the mouth direction used to decide when the load pours out.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from excavsim import constants
from excavsim.errors import ModelError
from excavsim.readouts import element_id


def _polygon_centroid(xz: np.ndarray) -> tuple[np.ndarray, float]:
    """Centroid and area of a closed polygon (shoelace)."""
    x, z = xz[:, 0], xz[:, 1]
    xn, zn = np.roll(x, -1), np.roll(z, -1)
    cross = x * zn - xn * z
    area = cross.sum() / 2.0
    cx = ((x + xn) * cross).sum() / (6.0 * area)
    cz = ((z + zn) * cross).sum() / (6.0 * area)
    return np.array([cx, cz]), abs(area)


@dataclasses.dataclass(frozen=True)
class BucketGeometry:
    """Sampled bucket surface in the bucket body frame.

    Attributes:
        body_id: MuJoCo id of the bucket body.
        points: (n_profile, n_width, 3) sample points on the profile [m]; index 0 along the profile is
            the cutting edge.
        normals: (n_profile, 3) outward unit normals of the outer surface (away from the interior).
        areas: (n_profile,) surface area each sample of one width column stands for [m^2].
        arc_length: (n_profile,) distance along the profile from the cutting edge [m].
        width: inner width [m]; capacity: struck capacity [m^3].
        load_centroid: where the load's weight acts [m].
        mouth_normal: outward unit normal of the strike line (the mouth).
        lips: (2, 3) cutting edge centre and back-wall top centre, where soil pours over.
        tip_site_id: id of the ``bucket_tip`` site (tip frame, Fig. 103).
    """

    body_id: int
    points: np.ndarray
    normals: np.ndarray
    areas: np.ndarray
    arc_length: np.ndarray
    width: float
    capacity: float
    load_centroid: np.ndarray
    mouth_normal: np.ndarray
    lips: np.ndarray
    tip_site_id: int

    @classmethod
    def from_model(cls, model: mujoco.MjModel, *, spacing_m: float = 0.02, n_width: int = 7) -> BucketGeometry:
        """Sample the bucket profile of ``model`` every ``spacing_m`` along it, ``n_width`` across."""
        body = element_id(model, "body", constants.BUCKET_BODY)
        tip = element_id(model, "site", constants.BUCKET_TIP_SITE)
        corners = []
        for i in range(constants.N_BUCKET_PROFILE_SITES):
            sid = element_id(model, "site", f"{constants.BUCKET_PROFILE_SITE_PREFIX}{i}")
            if model.site_bodyid[sid] != body:
                raise ModelError(f"profile site {i} is not on the {constants.BUCKET_BODY!r} body")
            corners.append(model.site_pos[sid].copy())
        corners = np.asarray(corners)
        if np.abs(corners[:, 1]).max() > 1e-9:
            raise ModelError("profile sites must lie in the bucket's mid-plane (y = 0)")
        xz = corners[:, [0, 2]]

        def numeric(name: str) -> float:
            nid = element_id(model, "numeric", name)
            return float(model.numeric_data[model.numeric_adr[nid]])

        width = numeric(constants.BUCKET_WIDTH_NUMERIC)
        capacity = numeric(constants.BUCKET_CAPACITY_NUMERIC)
        centroid, _ = _polygon_centroid(xz)

        # Resample each segment at <= spacing; normals point away from the interior centroid.
        pts, nrm, ds, s_acc = [], [], [], []
        s = 0.0
        for a, b in zip(xz[:-1], xz[1:]):
            seg = b - a
            length = float(np.hypot(*seg))
            n_seg = max(1, int(np.ceil(length / spacing_m)))
            t = (np.arange(n_seg) + 0.5) / n_seg
            normal = np.array([seg[1], -seg[0]]) / length
            if np.dot((a + b) / 2 - centroid, normal) < 0:
                normal = -normal
            for ti in t:
                pts.append(a + ti * seg)
                nrm.append(normal)
                ds.append(length / n_seg)
                s_acc.append(s + ti * length)
            s += length
        # The cutting edge itself is sample 0.
        edge_normal = nrm[0]
        pts.insert(0, xz[0])
        nrm.insert(0, edge_normal)
        ds.insert(0, 0.0)
        s_acc.insert(0, 0.0)
        pts = np.asarray(pts)
        ys = (np.arange(n_width) + 0.5) / n_width * width - width / 2
        points = np.zeros((len(pts), n_width, 3))
        points[:, :, 0] = pts[:, None, 0]
        points[:, :, 1] = ys[None, :]
        points[:, :, 2] = pts[:, None, 1]
        normals = np.zeros((len(pts), 3))
        normals[:, 0] = np.asarray(nrm)[:, 0]
        normals[:, 2] = np.asarray(nrm)[:, 1]
        strike = xz[0] - xz[-1]
        mouth = np.array([strike[1], -strike[0]]) / np.hypot(*strike)
        if np.dot((xz[0] + xz[-1]) / 2 - centroid, mouth) < 0:
            mouth = -mouth
        return cls(
            body_id=body,
            points=points,
            normals=normals,
            areas=np.asarray(ds) * width / n_width,
            arc_length=np.asarray(s_acc),
            width=width,
            capacity=capacity,
            load_centroid=np.array([centroid[0], 0.0, centroid[1]]),
            mouth_normal=np.array([mouth[0], 0.0, mouth[1]]),
            lips=np.array([[xz[0][0], 0.0, xz[0][1]], [xz[-1][0], 0.0, xz[-1][1]]]),
            tip_site_id=tip,
        )

    @property
    def edge(self) -> np.ndarray:
        """(n_width, 3) samples along the cutting edge, body frame."""
        return self.points[0]
