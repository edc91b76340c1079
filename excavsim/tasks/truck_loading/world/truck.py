"""A dump truck beside the excavator's pit: its collision body, its bed's fill and volume account, its scanner.

Rowe 1997 §6.1 loads "a standard on-highway dump truck" with a 25 t excavator; the thesis gives no
truck dimensions, so :class:`TruckSpec`'s numbers are **assumed**, those of a tri-axle on-highway dump
truck: an inside bed of 5.2 m x 2.3 m, its floor 1.5 m above the ground and its sides 1.2 m high (14.4 m^3
to the sides' top), a rated payload of 12 t (Rowe §6.2: six buckets of the 25 t machine fill one truck;
6 x 1.1 m^3 heaped x ~1.7 t/m^3 = 11-12 t).

* The **collision body** (:func:`add_truck`): a chassis, the bed's floor, four sides and a cab, boxes
  added to the excavator's scene with MuJoCo's model editing (``mujoco.MjSpec``), so the generated model
  files stay as they are. Its geoms collide with the machine's collision geoms (``conaffinity`` 2, as the
  pit's ground slabs).
* The **bed** (:class:`TruckBed`): a layered fill on the bed's floor, a heightfield of its own over the
  inside (rows along the truck's y, columns along its x, ``cell_m``), with its own volume account. Soil
  the bucket pours lands as the world's soil model drops it (:meth:`~excavsim.world.soil.SoilModel._pour`:
  the load beyond what the tilted bucket holds leaves over the lower lip and falls straight down, spread
  over a disc of the bucket's half-width); :meth:`TruckBed.catch` takes the part of that disc over the
  bed's inside and leaves the rest to the ground (the pit, or the spoil account outside it: the spillage).
  The fill then settles to the soil's angle of repose inside the sides (:func:`~excavsim.world.settle.settle`;
  no soil crosses the grid's border, so the sides hold it; a heap above the sides stays on the bed:
  simplified, a real heap that high would slide off).
* The **bed scanner** (:class:`BedScanner`): a laser on a mast over the truck (assumed: Rowe's range
  finders sit on the cab, §6.1, and §5.4.3 notes the sides may hide the bed from them; a mast sees the
  whole bed), rays cast with :func:`~excavsim.world.raycast.cast` at the fill's heightfield with the sides
  as occluding boxes, each range with Gaussian noise: points the mind bins into a map of the bed.

:class:`TruckWorld` is the :class:`~excavsim.world.hydraulics.ExcavatorWorld` with the truck parked
beside the pit: its soil model's poured soil goes through the bed first, and it reads cylinder pressures.
"""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np

from excavsim.errors import ExcavsimError
from excavsim.world import raycast
from excavsim.world.hydraulics import ExcavatorWorld
from excavsim.world.settle import settle


@dataclasses.dataclass(frozen=True)
class TruckSpec:
    """Where the truck is parked and its bed's dimensions (assumed; see the module docstring).

    Attributes:
        x_m, y_m: the bed's centre on the ground, world frame [m] (the swing axis is the origin).
        yaw_deg: the truck's heading (its x axis, tailgate to cab is -x) from the world x axis [deg].
        length_m, width_m: the bed's inside length (truck x) and width (truck y) [m].
        floor_m: the bed floor's height above the ground [m]; side_m: the sides' height above the floor [m].
        payload_kg: the rated payload [kg].
        cell_m: the fill heightfield's spacing [m].
        wall_m: the sides' thickness [m].
        scanner_height_m: the bed scanner's height above the ground, on a mast beside the bed [m].
    """

    x_m: float = 0.0
    y_m: float = 7.6
    yaw_deg: float = 0.0
    length_m: float = 5.2
    width_m: float = 2.3
    floor_m: float = 1.5
    side_m: float = 1.2
    payload_kg: float = 12000.0
    cell_m: float = 0.1
    wall_m: float = 0.08
    scanner_height_m: float = 7.0

    def __post_init__(self):
        if not (self.length_m > 4 * self.cell_m and self.width_m > 4 * self.cell_m and self.cell_m > 0):
            raise ExcavsimError(f"truck: the bed must be at least 4 cells long and wide; given {self!r}")
        if not (self.floor_m > 0 and self.side_m > 0 and self.payload_kg > 0 and self.wall_m > 0):
            raise ExcavsimError(f"truck: floor, side, payload and wall must be positive; given {self!r}")

    @property
    def side_top_m(self) -> float:
        """Height of the sides' top above the ground [m]: what the bucket must clear (Rowe 1997 Fig. 3)."""
        return self.floor_m + self.side_m

    @property
    def volume_m3(self) -> float:
        """The bed's volume up to the sides' top [m^3]."""
        return self.length_m * self.width_m * self.side_m

    @property
    def heading(self) -> float:
        return math.radians(self.yaw_deg)

    def to_local(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        """World (x, y) to the bed's frame (origin at the bed's centre, u along the truck, v across)."""
        c, s = math.cos(self.heading), math.sin(self.heading)
        dx, dy = np.asarray(x, float) - self.x_m, np.asarray(y, float) - self.y_m
        return c * dx + s * dy, -s * dx + c * dy

    def to_world(self, u, v) -> tuple[np.ndarray, np.ndarray]:
        """The bed's frame to world (x, y)."""
        c, s = math.cos(self.heading), math.sin(self.heading)
        u, v = np.asarray(u, float), np.asarray(v, float)
        return self.x_m + c * u - s * v, self.y_m + s * u + c * v

    def boxes(self) -> list[tuple[str, tuple[float, float, float], tuple[float, float, float]]]:
        """The collision boxes (name, centre in the bed's frame with z from the ground, half sizes) [m]."""
        L, W, f, h, t = self.length_m, self.width_m, self.floor_m, self.side_m, self.wall_m
        return [
            ("truck_chassis", (0.6, 0.0, 0.5 * (f - 0.1)), (0.5 * L + 1.3, 0.5 * W, 0.5 * (f - 0.1))),
            ("truck_floor", (0.0, 0.0, f - 0.05), (0.5 * L + t, 0.5 * W + t, 0.05)),
            ("truck_side_near", (0.0, -0.5 * W - 0.5 * t, f + 0.5 * h), (0.5 * L + t, 0.5 * t, 0.5 * h)),
            ("truck_side_far", (0.0, 0.5 * W + 0.5 * t, f + 0.5 * h), (0.5 * L + t, 0.5 * t, 0.5 * h)),
            ("truck_tailgate", (0.5 * L + 0.5 * t, 0.0, f + 0.5 * h), (0.5 * t, 0.5 * W, 0.5 * h)),
            ("truck_headboard", (-0.5 * L - 0.5 * t, 0.0, f + 0.5 * h), (0.5 * t, 0.5 * W, 0.5 * h)),
            ("truck_cab", (-0.5 * L - 1.2, 0.0, 0.5 * (f + h + 0.3)), (0.9, 0.5 * W, 0.5 * (f + h + 0.3))),
        ]


def add_truck(spec: mujoco.MjSpec, truck: TruckSpec) -> None:
    """Add the truck's collision body (boxes, ``conaffinity`` 2: the machine's collision geoms hit them)
    and its scanner's site to a model being edited."""
    body = spec.worldbody.add_body(name="truck", pos=[truck.x_m, truck.y_m, 0.0],
                                   quat=[math.cos(truck.heading / 2), 0.0, 0.0, math.sin(truck.heading / 2)])
    for name, centre, half in truck.boxes():
        rgba = [0.75, 0.55, 0.1, 1.0] if name != "truck_cab" else [0.8, 0.2, 0.15, 1.0]
        body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_BOX, pos=list(centre), size=list(half),
                      contype=0, conaffinity=2, group=1, rgba=rgba)
    body.add_site(name="truck_bed_scanner", pos=[0.0, 0.5 * truck.width_m + 1.0, truck.scanner_height_m],
                  size=[0.05, 0.05, 0.05], group=4)


class TruckBed:
    """The bed's fill: a heightfield over the bed's inside [m of soil above the floor] and its account.

    Args:
        truck: the truck's numbers.
        repose_rad: the soil's angle of repose (the fill settles to it).
    """

    def __init__(self, truck: TruckSpec, repose_rad: float):
        self.truck = truck
        self.repose = float(repose_rad)
        self.cell = truck.cell_m
        self.ncols = int(round(truck.length_m / self.cell))
        self.nrows = int(round(truck.width_m / self.cell))
        self.fill = np.zeros((self.nrows, self.ncols))  # soil depth on the floor at each cell's centre [m]
        self.caught_m3 = 0.0  # everything the bed has caught [m^3]

    @property
    def cell_area(self) -> float:
        return self.cell * self.cell

    def volume(self) -> float:
        """Soil in the bed [m^3]."""
        return float(self.fill.sum() * self.cell_area)

    def centres_local(self) -> tuple[np.ndarray, np.ndarray]:
        """Cell centres in the bed's frame: u (ncols,), v (nrows,) [m]."""
        u = -0.5 * self.truck.length_m + (np.arange(self.ncols) + 0.5) * self.cell
        v = -0.5 * self.truck.width_m + (np.arange(self.nrows) + 0.5) * self.cell
        return u, v

    def inside(self, x, y) -> np.ndarray:
        """Whether world points lie over the bed's inside."""
        u, v = self.truck.to_local(x, y)
        return (np.abs(u) < 0.5 * self.truck.length_m) & (np.abs(v) < 0.5 * self.truck.width_m)

    def catch(self, x: np.ndarray, y: np.ndarray, volumes: np.ndarray, radius_m: float) -> tuple[np.ndarray, float]:
        """Soil falling at world points, each volume spread evenly over a disc of ``radius_m`` (the soil
        model's pour): the part over the bed's inside lands on the fill; returns the volumes left to fall
        elsewhere (per point) and the volume caught [m^3]."""
        x, y = np.atleast_1d(np.asarray(x, float)), np.atleast_1d(np.asarray(y, float))
        volumes = np.broadcast_to(np.asarray(volumes, float), x.shape)
        k = max(0, int(math.floor(radius_m / self.cell)))
        di, dj = np.mgrid[-k:k + 1, -k:k + 1]
        disc = (di * di + dj * dj) * self.cell ** 2 <= radius_m ** 2 + 1e-12
        ox, oy = di[disc] * self.cell, dj[disc] * self.cell
        rest = np.array(volumes, dtype=float)
        caught = 0.0
        for i, (px, py, v) in enumerate(zip(x, y, volumes)):
            if v <= 0:
                continue
            u, w = self.truck.to_local(px + ox, py + oy)
            col = np.floor((u + 0.5 * self.truck.length_m) / self.cell).astype(int)
            row = np.floor((w + 0.5 * self.truck.width_m) / self.cell).astype(int)
            ok = (col >= 0) & (col < self.ncols) & (row >= 0) & (row < self.nrows)
            if not ok.any():
                continue
            share = v / len(ox)
            np.add.at(self.fill, (row[ok], col[ok]), share / self.cell_area)
            got = share * int(ok.sum())
            rest[i] = v - got
            caught += got
        self.caught_m3 += caught
        if caught > 0:
            self.settle()
        return rest, caught

    def settle(self) -> None:
        """Let the fill slide to the angle of repose inside the sides (volume conserved)."""
        settle(self.fill, self.cell, self.repose, tolerance_m=1e-3, max_iterations=400)

    def centroid_offset(self) -> tuple[float, float]:
        """The load's centre of volume in the bed's frame (u along the truck, v across) [m]; (0, 0) empty."""
        total = self.fill.sum()
        if total <= 0:
            return 0.0, 0.0
        u, v = self.centres_local()
        return float((self.fill.sum(axis=0) * u).sum() / total), float((self.fill.sum(axis=1) * v).sum() / total)

    def surface_z(self) -> np.ndarray:
        """The fill's surface height above the ground at each cell (nrows, ncols) [m]."""
        return self.truck.floor_m + self.fill


class BedScanner:
    """A laser on a mast over the truck: ranges to the bed's fill (or its sides), with noise (module docstring).

    Args:
        bed: the bed it looks into.
        origin: the laser's position, world frame [m].
        rng: the noise's random stream.
        noise_m: the range noise's standard deviation [m] (assumed).
        n_u, n_v: rays along and across the truck.
    """

    def __init__(self, bed: TruckBed, origin: np.ndarray, rng: np.random.Generator, *, noise_m: float = 0.02,
                 n_u: int = 80, n_v: int = 40):
        self.bed, self.origin, self.rng, self.noise_m = bed, np.asarray(origin, float), rng, float(noise_m)
        t = bed.truck
        u = np.linspace(-0.5 * t.length_m, 0.5 * t.length_m, n_u)
        v = np.linspace(-0.5 * t.width_m, 0.5 * t.width_m, n_v)
        uu, vv = np.meshgrid(u, v)
        x, y = t.to_world(uu.ravel(), vv.ravel())
        aim = np.stack([x, y, np.full(x.shape, t.floor_m)], axis=1) - self.origin
        self.dirs = np.ascontiguousarray(aim / np.linalg.norm(aim, axis=1, keepdims=True))
        self._boxes = self._side_boxes()

    def _side_boxes(self) -> np.ndarray:
        t = self.bed.truck
        rot = np.array([[math.cos(t.heading), -math.sin(t.heading), 0.0],
                        [math.sin(t.heading), math.cos(t.heading), 0.0], [0.0, 0.0, 1.0]])
        rows = []
        for name, centre, half in t.boxes():
            if name in ("truck_side_near", "truck_side_far", "truck_tailgate", "truck_headboard"):
                cx, cy = t.to_world(centre[0], centre[1])
                rows.append(np.r_[float(cx), float(cy), centre[2], rot.ravel(), half])
        return np.ascontiguousarray(np.array(rows))

    def scan(self) -> np.ndarray:
        """(n, 3) world points the rays hit (the fill or the sides' tops), each range with noise [m]."""
        b, t = self.bed, self.bed.truck
        # the fill as a heightfield in world coordinates: the bed is axis-aligned in its own frame, so cast
        # in that frame (rotate the origin and the directions by -yaw) with the fill at the floor's height
        c, s = math.cos(t.heading), math.sin(t.heading)
        ou, ov = t.to_local(self.origin[0], self.origin[1])
        d = self.dirs
        du, dv = c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]
        dirs_local = np.ascontiguousarray(np.stack([du, dv, d[:, 2]], axis=1))
        boxes = self._boxes.copy()
        for k in range(len(boxes)):  # boxes in the bed's frame: centres back, rotation identity
            bu, bv = t.to_local(boxes[k, 0], boxes[k, 1])
            boxes[k, 0], boxes[k, 1] = bu, bv
            boxes[k, 3:12] = np.eye(3).ravel()
        h = np.ascontiguousarray(b.fill)
        n = len(d)
        out_t, out_cos, out_kind = np.empty(n), np.empty(n), np.empty(n, np.int64)
        raycast.cast(h, -0.5 * t.length_m + 0.5 * b.cell, -0.5 * t.width_m + 0.5 * b.cell, b.cell, t.floor_m,
                     t.floor_m + float(h.max()) + 1e-6, boxes, np.array([float(ou), float(ov), self.origin[2]]),
                     dirs_local, 100.0, out_t, out_cos, out_kind)
        hit = np.isfinite(out_t)
        rng = out_t[hit] + self.rng.normal(0.0, self.noise_m, int(hit.sum()))
        return self.origin + rng[:, None] * d[hit]


class TruckWorld(ExcavatorWorld):
    """An :class:`~excavsim.world.hydraulics.ExcavatorWorld` with a dump truck parked beside its pit.

    Args:
        machine, soil, scene, seed, keyframe: as :class:`~excavsim.world.hydraulics.ExcavatorWorld`'s.
        truck: where the truck is and its bed (default :class:`TruckSpec`'s).
    """

    def __init__(self, machine: str, soil=None, scene=None, *, seed: int = 0, keyframe: str = "home",
                 truck: TruckSpec | None = None):
        self.truck = truck or TruckSpec()
        super().__init__(machine, soil, scene, seed=seed, keyframe=keyframe)
        self.bed = TruckBed(self.truck, self.soil.soil.repose)
        self.soil.catchers.append(self.bed.catch)
        site = self.model.site("truck_bed_scanner").id
        self.bed_scanner = BedScanner(self.bed, self.data.site_xpos[site].copy(), np.random.default_rng((seed, 34)))
        self._areas = [(c.area_retract_m2, c.area_extend_m2)
                       for c in (self.spec.boom_cyl, self.spec.stick_cyl, self.spec.bucket_cyl)]
        # Called with the world after every control step (the episode's observers); read-only use.
        self.step_hooks: list = []
        self.hauled_m3 = 0.0  # soil in the trucks that have left [m^3]

    def step_rates(self, rates: np.ndarray) -> np.ndarray:
        """One control step (:meth:`ExcavatorWorld.step_rates`, which :meth:`ExcavatorWorld.step` calls too),
        then the step hooks."""
        q = super().step_rates(rates)
        for hook in self.step_hooks:
            hook(self)
        return q

    def _compile(self) -> mujoco.MjModel:
        spec = mujoco.MjSpec.from_file(str(self.spec.scene_xml))
        add_truck(spec, self.truck)
        return spec.compile()

    @property
    def time(self) -> float:
        """Simulated time [s]."""
        return float(self.data.time)

    def cylinder_pressures(self) -> np.ndarray:
        """(3,) the boom, stick and bucket cylinders' working pressures [Pa]: the cylinder force over the
        piston area when it pushes, over the annulus when it pulls (the pressure sensors of Rowe 1997
        §6.1; positive: pushing). Friction and the other chamber's pressure are not modelled."""
        f = self.cylinder_forces()[1:]
        return np.array([fi / (a_ext if fi >= 0 else a_ret) for fi, (a_ret, a_ext) in zip(f, self._areas)])

    def haul(self) -> float:
        """The loaded truck drives off and an empty one parks in its place: the bed's soil moves to the
        hauled account; returns it [m^3]."""
        v = self.bed.volume()
        self.hauled_m3 += v
        self.bed.fill[:] = 0.0
        return v

    def volume_account(self) -> dict[str, float]:
        """Where the soil is [m^3] (privileged truth): the pit, the bucket, the bed, the ground outside
        the pit (spoil), the trucks that left (hauled), and their total, which stays constant."""
        v = self.soil.volumes()
        bed = self.bed.volume()
        return {"pit": float(v.box), "bucket": float(v.bucket), "bed": bed, "spoil": float(v.spoil),
                "hauled": self.hauled_m3, "total": float(v.box + v.bucket + v.spoil + bed + self.hauled_m3)}
