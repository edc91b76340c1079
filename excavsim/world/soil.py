"""The world's soil: cutting, filling, spilling, dumping, settlement, and the forces on the bucket.

:class:`SoilModel` is the truth model of the bucket-soil interaction. Once per control step
(:meth:`SoilModel.step`) it reads the bucket's pose and velocity from MuJoCo, reshapes the terrain,
moves soil between the box, the bucket and the spoil, and returns the wrench the soil exerts on the
bucket, which :class:`~excavsim.world.simulation.Simulation` applies through ``xfrc_applied`` so the
F/T sensor measures it. Forces are held constant over the physics substeps of a control step.

Model (and where it simplifies):

* **Cutting** (DESIGN.md §3): samples swept by the cutting edge are lowered to the edge's height; the
  removed volume enters the bucket up to its heaped capacity; beyond it the cut soil is deposited
  just ahead of the edge (surcharge) and spreads by settlement. Only the edge reshapes the terrain:
  the bottom and back of the bucket press on the soil (below) but do not displace it.
* **Cutting resistance**: the wedge model, eq. 8 (000_a3ca905d8c6d92bf.txt §5.1.2), per width sample,
  with depth ``d`` of the edge below the surface just ahead of it, the rake of the blade, ``beta``
  minimizing ``N_gamma`` (tabulated per rake; below 5 deg the blade slices along itself, outside the
  model, and the factors are held at 5 deg), adhesion (eq. 5) and a surcharge equal to the soil
  above the edge level on the wedge ahead plus a share of the load, entering as its weight over the
  denominator of eq. 5 (eq. 7 with ``q d (cot rho + cot beta)`` = surcharge weight per width). The
  force acts along ``-sin(delta) x_t - cos(delta) z_t`` in the tip frame (the angle
  ``pi/2 - rho - delta`` from horizontal of eq. 8). It builds elastically with the edge's travel
  into the soil (``cut_stiffness_n_per_m``) up to the failure value and relaxes when the edge backs
  off: it acts only while the edge moves into soil, and is continuous when the arm stalls.
* **Truth terms the static model misses** (``SoilTruthConfig``): a speed factor ``1 + k v``
  (Fig. 63), saw-tooth build-up and release over successive failure surfaces spaced ``d cot beta``
  (Fig. 54), a log-normal, spatially correlated strength factor, buried rocks that push the edge
  back (they are never excavated), and F/T noise (added to observations by the Simulation).
* **Bearing and friction** on the outer surface (Fig. 19, rake below ``alpha + epsilon``): a rate
  form elasto-plastic pressure, between the at-rest earth pressure ``K0 gamma g p`` (Jaky,
  ``K0 = 1 - sin phi``) and the strip-footing bearing capacity ``c N_c + gamma g p N_q +
  0.5 gamma g B N_gamma`` (Prandtl-Reissner-Vesic factors, not from the thesis), mobilized over
  ``bearing_mobilisation_m`` of travel into the soil; soil-tool friction ``tan(delta)`` opposes the
  slip in the bucket's own plane only (not across its width), regularized so that its damping stays
  below ``friction_mass_kg / dt``: forces are updated once per control step, explicitly.
* **Settlement** runs every ``settle.interval_s`` on the cells changed since the last time, but only
  while the edge is out of the soil: the bucket holds up the faces it has just cut, and soil that
  slumped into the space the bucket occupies would have nowhere to go.
* **Load**: the load's weight acts at the centroid of the bucket interior (its inertia is ignored).
  Once the edge is out of the soil, the bucket holds its heaped capacity while the mouth tilt from
  vertical is below ``spill_start_deg``, nothing beyond ``dump_angle_deg``, linearly between; the
  excess pours over the lower lip and lands below it (or in the spoil account when that is outside
  the box).
"""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np
from scipy import ndimage

from excavsim.config import SceneConfig, SoilParams
from excavsim.mechanics.bearing import bearing_factors
from excavsim.mechanics.wedge import MIN_RAKE_RAD, WedgeTable
from excavsim.world import kernels
from excavsim.world.bucket import BucketGeometry
from excavsim.world.settle import SettleResult, settle
from excavsim.world.terrain import SoilGrid

_EDGE_EXCLUSION_M = 0.03  # profile within this arc length of the edge belongs to the cutting face


@dataclasses.dataclass(frozen=True)
class Volumes:
    """Where the soil is [m^3]: in the box, in the bucket, in spoil outside the box, and the total."""

    box: float
    bucket: float
    spoil: float

    @property
    def total(self) -> float:
        return self.box + self.bucket + self.spoil


class SoilContact:
    """The soil's action on the bucket over one control step (privileged truth, world frame).

    Forces are on the bucket [N]; ``torque`` is the total moment about the bucket's centre of mass.
    A thin view of the kernel's output vector, so that creating one every step costs little.
    """

    __slots__ = ("time", "_v", "spilled_volume_m3", "poured_volume_m3")

    def __init__(self, time: float, values: np.ndarray, spilled: float, poured: float):
        self.time = time
        self._v = values
        self.spilled_volume_m3 = spilled
        self.poured_volume_m3 = poured

    depth_m = property(lambda self: float(self._v[kernels.O_DEPTH]), doc="mean edge depth below the surface [m]")
    rake_rad = property(lambda self: float(self._v[kernels.O_RAKE]), doc="rake of the blade [rad]")
    cutting_speed_m_s = property(lambda self: float(self._v[kernels.O_SPEED]), doc="edge speed into the soil")
    wedge_failure_force_n = property(lambda self: float(self._v[kernels.O_FAIL]),
                                     doc="failure force of the wedge with the truth terms [N]")
    cutting_force = property(lambda self: self._v[kernels.O_FCUT:kernels.O_FCUT + 3],
                             doc="wedge force on the bucket [N]")
    bearing_force = property(lambda self: self._v[kernels.O_FBEAR:kernels.O_FBEAR + 3],
                             doc="bearing and friction on the outer surface [N]")
    rock_force = property(lambda self: self._v[kernels.O_FROCK:kernels.O_FROCK + 3], doc="rock contact force [N]")
    force = property(lambda self: self._v[kernels.O_FORCE:kernels.O_FORCE + 3],
                     doc="total soil force on the bucket, load weight included [N]")
    torque = property(lambda self: self._v[kernels.O_TORQUE:kernels.O_TORQUE + 3],
                      doc="total moment about the bucket's centre of mass [N m]")
    cut_volume_m3 = property(lambda self: float(self._v[kernels.O_CUT]), doc="soil cut this step [m^3]")
    max_penetration_m = property(lambda self: float(self._v[kernels.O_PMAX]),
                                 doc="deepest outer-surface sample below the surface [m]")

    @property
    def load_weight(self) -> np.ndarray:
        """Weight of the load in the bucket [N]."""
        return np.array([0.0, 0.0, self._v[kernels.O_WEIGHT]])

    def __repr__(self) -> str:
        return (f"SoilContact(t={self.time:.3f}, depth={self.depth_m:.3f}, force={np.round(self.force, 1)}, "
                f"cut={self.cut_volume_m3:.2e})")


def strength_field(shape: tuple[int, int], cell: float, std: float, length_m: float,
                   rng: np.random.Generator) -> np.ndarray:
    """A log-normal, spatially correlated soil-strength factor of mean 1 over the grid."""
    if std == 0:
        return np.ones(shape)
    white = rng.standard_normal(shape)
    smooth = ndimage.gaussian_filter(white, sigma=length_m / cell, mode="reflect")
    smooth /= max(smooth.std(), 1e-12)
    return np.exp(std * smooth - 0.5 * std * std)


class SoilModel:
    """Truth model of the soil and of its interaction with the bucket.

    Args:
        model: the compiled scene (hfield, bucket body, profile sites).
        scene: the scene configuration (soil preset, settlement, truth terms, bucket handling).
        soil: the soil parameters.
        rng: the episode's random generator (heterogeneity field, rocks).
    """

    def __init__(self, model: mujoco.MjModel, scene: SceneConfig, soil: SoilParams, rng: np.random.Generator):
        self.model = model
        self.scene = scene
        self.soil = soil
        self.grid = SoilGrid.from_model(model, scene.initial_soil_height_m)
        self.bucket = BucketGeometry.from_model(model)
        self.table = WedgeTable.for_soil(soil)
        self.gravity = float(-model.opt.gravity[2])
        self.heaped_capacity = self.bucket.capacity * scene.bucket.heaped_capacity_factor
        self.strength = strength_field(self.grid.shape, self.grid.cell, scene.truth.heterogeneity_std,
                                       scene.truth.heterogeneity_length_m, rng)
        self.rocks = np.ascontiguousarray(self._place_rocks(rng))
        g, gamma = self.gravity, soil.density_kg_m3
        n_c, n_q, n_g = bearing_factors(soil.phi)
        self._k_rest = (1.0 - math.sin(soil.phi)) * gamma * g
        self._q_ult0 = soil.cohesion_pa * n_c + 0.5 * gamma * g * self.bucket.width * n_g
        self._q_ult_slope = gamma * g * n_q
        self._k_mob = self._q_ult0 / scene.bucket.bearing_mobilisation_m
        self._active = self.bucket.arc_length > _EDGE_EXCLUSION_M
        n_prof, n_w, _ = self.bucket.points.shape
        self._sigma = np.zeros(n_prof * n_w)
        self._active_flat = np.repeat(self._active, n_w)
        self._normals_flat_body = np.repeat(self.bucket.normals, n_w, axis=0)
        self._areas_flat = np.repeat(self.bucket.areas, n_w)
        self._points_flat_body = self.bucket.points.reshape(-1, 3)
        half = self.bucket.width / n_w / 2
        edge = self.bucket.edge
        self._edge_body = np.ascontiguousarray(edge)
        self._edge_ends_body = np.stack([edge[0] - [0, half, 0], edge[-1] + [0, half, 0]])
        self._edge_pack = np.ascontiguousarray(np.vstack([self._edge_body, self._edge_ends_body,
                                                          self.bucket.load_centroid]))
        self._surf_pack = np.ascontiguousarray(np.column_stack([
            self._points_flat_body, self._normals_flat_body, self._areas_flat, self._active_flat.astype(float)]))
        tb = self.table
        self._table_pack = np.ascontiguousarray(np.stack([tb.beta, tb.n_gamma, tb.n_c, tb.n_a, tb.denominator]))
        self._gamma_g = soil.density_kg_m3 * self.gravity
        p = np.zeros(kernels.P_LEN)
        p[kernels.P_GAMMA_G] = self._gamma_g
        p[kernels.P_COHESION] = soil.cohesion_pa
        p[kernels.P_ADHESION] = soil.adhesion_pa
        p[kernels.P_SIN_DELTA] = math.sin(soil.delta)
        p[kernels.P_COS_DELTA] = math.cos(soil.delta)
        p[kernels.P_WIDTH] = self.bucket.width
        p[kernels.P_K_CUT] = scene.bucket.cut_stiffness_n_per_m
        p[kernels.P_SPEED] = scene.truth.speed_coefficient_s_per_m
        p[kernels.P_SAW] = scene.truth.sawtooth_amplitude
        p[kernels.P_LOAD_SURCHARGE] = scene.bucket.load_surcharge_fraction
        p[kernels.P_CAPACITY] = self.heaped_capacity
        p[kernels.P_K_REST] = self._k_rest
        p[kernels.P_Q0] = self._q_ult0
        p[kernels.P_Q_SLOPE] = self._q_ult_slope
        p[kernels.P_K_MOB] = self._k_mob
        p[kernels.P_MU] = math.tan(soil.delta)
        p[kernels.P_V_EPS] = scene.bucket.friction_velocity_m_s
        p[kernels.P_K_ROCK] = scene.bucket.rock_stiffness_n_per_m
        p[kernels.P_RAKE_MIN] = max(self.table.rake_min, MIN_RAKE_RAD)
        p[kernels.P_M_REF] = scene.bucket.friction_mass_kg
        self._params = p
        self._state = np.zeros(kernels.S_LEN)
        self._out = np.zeros(kernels.O_LEN)
        self._vel6 = np.zeros(6)
        self.spoil = 0.0
        self._since_settle = 0.0
        self._window = np.zeros(4, np.int64)
        self._hfield = self.grid.hfield_view(model)
        self._load_centroid = self.bucket.load_centroid
        self.initial_volume = self.volumes().total
        self.grid.write_hfield(self._hfield)

    # -- accounting -----------------------------------------------------------------------------
    def volumes(self) -> Volumes:
        """Soil in the box, in the bucket and in spoil [m^3]."""
        return Volumes(self.grid.volume(), self.load, self.spoil)

    def _place_rocks(self, rng: np.random.Generator) -> np.ndarray:
        truth = self.scene.truth
        g = self.grid
        n = truth.rocks
        if n == 0:
            return np.zeros((0, 4))
        r = rng.uniform(truth.rock_radius_min_m, truth.rock_radius_max_m, n)
        x = rng.uniform(g.x0 + 0.2, g.x1 - 0.2, n)
        y = rng.uniform(g.y0 + 0.2, g.y1 - 0.2, n)
        z = g.z0 + rng.uniform(0.05, max(0.06, self.scene.initial_soil_height_m - 0.05), n)
        return np.stack([x, y, z, r], axis=1)

    # -- the step -------------------------------------------------------------------------------
    @property
    def load(self) -> float:
        """Soil in the bucket [m^3]."""
        return float(self._state[kernels.S_LOAD])

    @load.setter
    def load(self, value: float) -> None:
        self._state[kernels.S_LOAD] = value

    @property
    def cut_force_state(self) -> float:
        """The elastic cutting force built up in the wedge ahead of the edge [N]."""
        return float(self._state[kernels.S_CUT_FORCE])

    def step(self, data: mujoco.MjData, dt: float) -> SoilContact:
        """Advance the soil by one control step of ``dt`` seconds and return its action on the bucket."""
        b = self.bucket
        grid = self.grid
        mujoco.mj_objectVelocity(self.model, data, mujoco.mjtObj.mjOBJ_BODY, b.body_id, self._vel6, 0)
        self._params[kernels.P_DT] = dt
        out = self._out
        tb = self.table
        kernels.soil_step(grid.heights, grid.x0, grid.y0, grid.cell, grid.z0, data.xpos, data.xmat, data.xipos,
                          data.site_xmat, b.body_id, b.tip_site_id, self._vel6, self._edge_pack, self._surf_pack,
                          self._sigma, tb.rake_min, tb.rake_step, self._table_pack, self.strength, self.rocks,
                          self._state, self._params, self._window, out)
        out = out.copy()
        cut_volume = float(out[kernels.O_CUT])
        spilled = cut_volume - float(out[kernels.O_TAKE])
        poured = 0.0
        if cut_volume > 0:
            w = self._window
            grid.mark(int(w[0]), int(w[1]), int(w[2]), int(w[3]))
            if spilled > 0:  # full bucket: the cut soil piles up just ahead of the edge
                rot = data.xmat[b.body_id].reshape(3, 3)
                edge = b.edge @ rot.T + data.xpos[b.body_id]
                drop = edge + out[kernels.O_AHEAD:kernels.O_AHEAD + 3] * (2 * grid.cell)
                self.spoil += grid.deposit(drop[:, 0], drop[:, 1], np.full(len(drop), spilled / len(drop)))
        elif out[kernels.O_DEPTH] == 0.0 and self.load > 0.0:
            poured = self._pour(data, out)
        if cut_volume > 0 or poured > 0:
            window = grid.peek_dirty()
            if window is not None:
                grid.write_hfield(self._hfield, window)
        # The bucket holds up the faces it has just cut: settle only once the edge is out of the soil.
        self._since_settle += dt
        if self._since_settle >= self.scene.settle.interval_s - 1e-12 and out[kernels.O_DEPTH] == 0.0:
            self.settle_changes()
        return SoilContact(float(data.time), out, spilled, poured)

    def _pour(self, data: mujoco.MjData, out: np.ndarray) -> float:
        """Let the load beyond what the tilted bucket holds pour over its lower lip; returns the volume."""
        b = self.bucket
        cfg = self.scene.bucket
        rot = data.xmat[b.body_id].reshape(3, 3)
        tilt = math.degrees(math.acos(min(max(float(rot[2] @ b.mouth_normal), -1.0), 1.0)))
        frac = (cfg.dump_angle_deg - tilt) / (cfg.dump_angle_deg - cfg.spill_start_deg)
        hold = self.heaped_capacity * min(max(frac, 0.0), 1.0)
        if self.load <= hold:
            return 0.0
        poured = self.load - hold
        self.load = hold
        org = data.xpos[b.body_id]
        lips = b.lips @ rot.T + org
        lip = lips[int(np.argmin(lips[:, 2]))]
        self.spoil += self.grid.deposit(lip[:1], lip[1:2], np.array([poured]), radius_m=b.width / 2)
        # the load's weight in the wrench was computed before pouring
        dw = self._gamma_g * poured
        arm = rot @ b.load_centroid + org - data.xipos[b.body_id]
        out[kernels.O_WEIGHT] += dw
        out[kernels.O_FORCE + 2] += dw
        out[kernels.O_TORQUE] += arm[1] * dw
        out[kernels.O_TORQUE + 1] -= arm[0] * dw
        return poured

    # -- settlement -----------------------------------------------------------------------------
    def settle_changes(self) -> SettleResult | None:
        """Settle the terrain starting from the cells changed since the last settle."""
        self._since_settle = 0.0
        window = self.grid.take_dirty()
        if window is None:
            return None
        r0, r1, c0, c1 = window
        cfg = self.scene.settle
        result = settle(self.grid.heights, self.grid.cell, self.soil.repose, tolerance_m=cfg.tolerance_m,
                        max_iterations=cfg.max_iterations, region=(r0, r1, c0, c1))
        self.grid.write_hfield(self._hfield)
        return result

    def settle_all(self, max_iterations: int | None = None) -> SettleResult:
        """Settle the whole terrain (e.g. at the end of a dig)."""
        self.grid.take_dirty()
        cfg = self.scene.settle
        result = settle(self.grid.heights, self.grid.cell, self.soil.repose, tolerance_m=cfg.tolerance_m,
                        max_iterations=max_iterations or cfg.max_iterations)
        self.grid.write_hfield(self._hfield)
        return result
