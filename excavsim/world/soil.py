"""The world's soil: cutting, filling, spilling, dumping, settlement, and the forces on the bucket.

:class:`SoilModel` is the truth model of the bucket-soil interaction. Once per control step
(:meth:`SoilModel.step`) it reads the bucket's pose and velocity from MuJoCo, reshapes the terrain,
moves soil between the box, the bucket and the spoil, and returns the wrench the soil exerts on the
bucket, which :class:`~excavsim.world.simulation.Simulation` applies through ``xfrc_applied`` so the
F/T sensor measures it. Forces are held constant over the physics substeps of a control step.

Model (and where it simplifies):

* **Cutting** (§7.1, §5.1.2): samples swept by the cutting edge are lowered to the edge's height; the
  removed volume enters the bucket up to its heaped capacity; beyond it the cut soil is deposited
  just ahead of the edge (surcharge) and spreads by settlement. Only the edge reshapes the terrain:
  the bottom and back of the bucket press on the soil (below) but do not displace it.
* **Cutting resistance**: the wedge model, eq. 8 (Singh 1995 §5.1.2), per width sample,
  with depth ``d`` of the edge below the surface just ahead of it (bilinear in the heightfield, so
  sub-cell), the rake of the blade, ``beta`` minimizing ``N_gamma`` (tabulated per rake; below 5 deg
  the blade slices along itself, outside the model, and the factors are held at 5 deg), adhesion
  (eq. 5) and the surcharge of the soil actually heaped on the wedge: the soil above the level of the
  surface ahead of the edge over the wedge's length ``d (cot rho + cot beta)``, entering as its
  weight over the denominator of eq. 5 (eq. 7 with ``q d (cot rho + cot beta)`` = surcharge weight
  per width); nothing heaps on a flat surface until the full bucket spills ahead. The bucket's load
  bears on the wedge too (``scene.bucket.load_surcharge``; Fig. 57's displaced soil as surcharge,
  §5.1.3's captive soil acting as the cutting surface), a share ``V / C`` of it growing with the
  fill of the heaped capacity (:func:`~excavsim.world.kernels.load_surcharge_volume`; the share is
  assumed), so short drags with a nearly empty bucket scale as ``d^2`` (Fig. 59) and a filling
  bucket's force grows with its load (Fig. 64: the wedge alone under-predicts as the tool proceeds). The force acts along ``-sin(delta) x_t - cos(delta) z_t`` in the tip frame
  (the angle ``pi/2 - rho - delta`` from horizontal of eq. 8).
* **Speed** (Fig. 63): the dynamic form of the Fundamental Equation of Earthmoving (McKyes 1985) adds
  the force that accelerates the soil entering the wedge, ``rho_s v^2 d N_acc w``, with ``v`` the
  edge's horizontal advance (:mod:`excavsim.mechanics.wedge_inertia`); for cohesive soils the
  cohesion and adhesion grow by ``cohesion_rate_per_decade`` per tenfold ``v`` above
  ``rate_reference_speed_m_s`` (the strain-rate effect on clay strength, about 10 % per log cycle,
  Kulhawy & Mayne 1990; the reference speed is assumed). Cohesionless sand has no rate effect here.
* **Failure cycle** (Figs. 53-54, :func:`~excavsim.world.kernels.failure_cycle`): the force builds
  elastically with the edge's travel (``cut_stiffness_n_per_m``) to the failure force, the wedge
  fails along its critical plane and the force drops by the brittleness index (post-peak softening,
  Bishop 1967; its value is assumed); the blade then pushes the failed wedge off while the next one
  takes up load, and the next failure comes after ``s d cot beta*`` of advance, ``s`` the strength
  factor where the new failure plane runs. Eq. 8 is the peak of each cycle ("the force just before
  failure", §5.1.2). It acts only while the edge moves into soil and is continuous when the arm stalls.
* **Truth terms the static model misses** (``SoilTruthConfig``): the rate effect and the failure
  cycle above, a log-normal, spatially correlated strength factor (interpolated at the middle of the
  failure plane; it scales the static part), buried rocks that push the edge back (they are never
  excavated), and F/T noise (added to observations by the Simulation).
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
* **A second truth**: with ``truth.model: dimaio`` the forces are those of DiMaio's bucket-ground
  model instead of the wedge, bearing and rocks (:mod:`excavsim.world.dimaio`); cutting, filling,
  spilling, pouring and settlement are the same, so the volume account is too.
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

from excavsim import constants
from excavsim.config import SceneConfig, SoilParams
from excavsim.mechanics.bearing import bearing_factors
from excavsim.mechanics.wedge import MIN_RAKE_RAD, WedgeTable
from excavsim.mechanics.wedge_inertia import acceleration_factor
from excavsim.world import dimaio, kernels, soil_records
from excavsim.world.bucket import BucketGeometry
from excavsim.world.settle import SettleResult, settle
from excavsim.world.terrain import SoilGrid

_EDGE_EXCLUSION_M = 0.03  # profile within this arc length of the edge belongs to the cutting face
_MAX_SPILL_ROWS = 24  # most rows of cells along the wedge a spill is spread over
_OBJ_BODY = mujoco.mjtObj.mjOBJ_BODY


@dataclasses.dataclass(frozen=True)
class Volumes:
    """Where the soil is [m^3]: in the box, in the bucket, in spoil outside the box, and the total."""

    box: float
    bucket: float
    spoil: float

    @property
    def total(self) -> float:
        return self.box + self.bucket + self.spoil


# Where the fields of the kernel's output record lie in its float64 view, the form a step's snapshot keeps.
_OUT = soil_records.float64_slots(soil_records.OUT)
# the force and then the torque, adjacent in the record: the wrench that xfrc_applied takes, in one slice
_WRENCH = slice(_OUT["force_n"].start, _OUT["torque_nm"].stop)
assert _OUT["force_n"].stop == _OUT["torque_nm"].start and _WRENCH.stop - _WRENCH.start == 6
_CUT, _TAKEN, _DEPTH = _OUT["cut_volume_m3"], _OUT["taken_volume_m3"], _OUT["depth_m"]


def _scalar(field: str, doc: str) -> property:
    i = _OUT[field]
    return property(lambda self: float(self._v[i]), doc=doc)


def _vector(field: str, doc: str) -> property:
    i = _OUT[field]
    return property(lambda self: self._v[i], doc=doc)


class SoilContact:
    """The soil's action on the bucket over one control step (privileged truth, world frame).

    Forces are on the bucket [N]; ``torque`` is the total moment about the bucket's centre of mass.
    A thin view of its own copy of the kernel's output record
    (:data:`~excavsim.world.soil_records.OUT`, kept as its float64 view), so that creating one
    every step costs little.
    """

    __slots__ = ("time", "_v", "spilled_volume_m3", "poured_volume_m3")

    def __init__(self, time: float, values: np.ndarray, spilled: float, poured: float):
        self.time = time
        self._v = values
        self.spilled_volume_m3 = spilled
        self.poured_volume_m3 = poured

    depth_m = _scalar("depth_m", "mean edge depth below the surface [m]")
    rake_rad = _scalar("rake_rad", "rake of the blade [rad]")
    cutting_speed_m_s = _scalar("cutting_speed_m_s", "edge speed into the soil [m/s]")
    advance_speed_m_s = _scalar("advance_speed_m_s", "edge's horizontal advance into the soil [m/s]")
    wedge_failure_force_n = _scalar("wedge_failure_force_n", "failure force of the wedge with the truth terms [N]")
    inertial_force_n = _scalar("inertial_force_n", "part of it that accelerates the soil entering the wedge [N]")
    cutting_force = _vector("cutting_force_n", "wedge force on the bucket [N]")
    bearing_force = _vector("bearing_force_n", "bearing and friction on the outer surface [N]")
    rock_force = _vector("rock_force_n", "rock contact force [N]")
    force = _vector("force_n", "total soil force on the bucket, load weight included [N]")
    torque = _vector("torque_nm", "total moment about the bucket's centre of mass [N m]")
    cut_volume_m3 = _scalar("cut_volume_m3", "soil cut this step [m^3]")
    max_penetration_m = _scalar("max_penetration_m", "deepest outer-surface sample below the surface [m]")

    @property
    def wedge_failed(self) -> bool:
        """Whether the wedge failed along its critical plane this step (the saw-tooth's drop)."""
        return bool(self._v[_OUT["wedge_failed"]] == 1.0)

    @property
    def wrench(self) -> np.ndarray:
        """The total force and then its moment (6,), ``force`` and ``torque`` in one view [N, N m]."""
        return self._v[_WRENCH]

    @property
    def load_weight(self) -> np.ndarray:
        """Weight of the load in the bucket [N]."""
        return np.array([0.0, 0.0, self._v[_OUT["load_weight_z_n"]]])

    @property
    def record(self) -> np.ndarray:
        """All of the step's output, as a ``(1,)`` :data:`~excavsim.world.soil_records.OUT` record (a view)."""
        return self._v.view(soil_records.OUT)

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


def _table_acceleration_factor(table: WedgeTable, soil: SoilParams) -> np.ndarray:
    """``N_acc`` of the dynamic earthmoving equation on the wedge table's rakes at their beta*
    (McKyes 1985; :func:`~excavsim.mechanics.wedge_inertia.acceleration_factor`); 0 where no wedge exists."""
    n = acceleration_factor(table.rake, table.beta, soil.phi, soil.delta)
    return np.where(np.isfinite(n), n, 0.0)


class SoilModel:
    """Truth model of the soil and of its interaction with the bucket.

    Args:
        model: the compiled scene (hfield, bucket body, profile sites).
        scene: the scene configuration (soil preset, settlement, truth terms, bucket handling).
        soil: the soil parameters.
        rng: the episode's random generator (heterogeneity field, rocks).

    Attributes:
        params: the kernel's constants, a :data:`~excavsim.world.soil_records.PARAMS` record built
            from ``scene`` and ``soil``; a field changed here changes the steps that follow.
        strength: (n_rows, n_cols) soil-strength factor on the grid's cells [-].
        rocks: (n_rocks, 4) buried rocks: centre x, y, z and radius [m].
        early_out: whether the wedge kernel skips its cutting and bearing loops while the bucket is
            clear of the terrain (:func:`~excavsim.world.kernels.clear_of_terrain`); the results are
            the same to the bit either way (True by default; False is the reference for tests).
        clear_steps: how many steps took that early-out.
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
        self._gamma_g = gamma * g
        n_c, n_q, n_g = bearing_factors(soil.phi)
        q_ult0 = soil.cohesion_pa * n_c + 0.5 * gamma * g * self.bucket.width * n_g
        self.params = soil_records.filled(
            soil_records.PARAMS,
            gamma_g_n_m3=self._gamma_g,
            density_kg_m3=gamma,
            cohesion_pa=soil.cohesion_pa,
            adhesion_pa=soil.adhesion_pa,
            sin_delta=math.sin(soil.delta),
            cos_delta=math.cos(soil.delta),
            mu=math.tan(soil.delta),
            rake_min_rad=max(self.table.rake_min, MIN_RAKE_RAD),
            table_rake0_rad=self.table.rake_min,
            table_rake_step_rad=self.table.rake_step,
            cut_stiffness_n_per_m=scene.bucket.cut_stiffness_n_per_m,
            capacity_m3=self.heaped_capacity,
            cohesion_rate_per_decade=scene.truth.cohesion_rate_per_decade,
            rate_reference_speed_m_s=scene.truth.rate_reference_speed_m_s,
            brittleness_index=scene.truth.brittleness_index,
            k_rest_pa_per_m=(1.0 - math.sin(soil.phi)) * gamma * g,
            q_ult0_pa=q_ult0,
            q_ult_slope_pa_per_m=gamma * g * n_q,
            k_mob_pa_per_m=q_ult0 / scene.bucket.bearing_mobilisation_m,
            friction_velocity_m_s=scene.bucket.friction_velocity_m_s,
            friction_mass_kg=scene.bucket.friction_mass_kg,
            rock_stiffness_n_per_m=scene.bucket.rock_stiffness_n_per_m,
            load_surcharge=1.0 if scene.bucket.load_surcharge else 0.0,
        )
        grid, b = self.grid, self.bucket
        self._grid_record = soil_records.filled(soil_records.GRID, x0_m=grid.x0, y0_m=grid.y0, cell_m=grid.cell,
                                                z0_m=grid.z0)
        n_prof, n_w, _ = b.points.shape
        half = b.width / n_w / 2
        self._edge = np.ascontiguousarray(b.edge)
        self._bucket_record = soil_records.filled(
            soil_records.BUCKET, body_id=b.body_id, tip_site_id=b.tip_site_id, width_m=b.width,
            edge_ends_m=np.stack([b.edge[0] - [0, half, 0], b.edge[-1] + [0, half, 0]]),
            load_centroid_m=b.load_centroid)
        self._surface = soil_records.filled(
            soil_records.SURFACE_SAMPLE, n_prof * n_w, point_m=b.points.reshape(-1, 3),
            normal=np.repeat(b.normals, n_w, axis=0), area_m2=np.repeat(b.areas, n_w),
            active=np.repeat(b.arc_length > _EDGE_EXCLUSION_M, n_w))
        tb = self.table
        self._table = soil_records.filled(soil_records.WEDGE_ROW, len(tb.rake), beta_rad=tb.beta, n_gamma=tb.n_gamma,
                                          n_c=tb.n_c, n_a=tb.n_a, denominator=tb.denominator,
                                          n_acc=_table_acceleration_factor(tb, soil))
        self._pressure = np.zeros(n_prof * n_w)
        # a box around every sample the kernel places on the bucket, for its clear-of-the-terrain test
        samples = np.concatenate([b.points.reshape(-1, 3), b.edge, self._bucket_record["edge_ends_m"][0]])
        self._box_body = np.ascontiguousarray(np.stack([samples.min(axis=0), samples.max(axis=0)]))
        self.early_out = True  # skip the contact loops while the bucket is clear of the terrain (same results)
        self.clear_steps = 0  # the steps that took that early-out
        self._body_id = b.body_id
        self._mj_data: mujoco.MjData | None = None
        self._mj_arrays: tuple = ()
        self._state = np.zeros(1, soil_records.STATE)
        self._load_m3 = self._state["load_m3"]  # field views, read and set from Python
        self._cut_force_n = self._state["cut_force_n"]
        self._out = np.zeros(1, soil_records.OUT)
        self._out_f8 = self._out.view(np.float64)  # the same bytes: a step's snapshot is a plain copy
        self._window = self._out["window"][0]
        self._vel6 = np.zeros(6)
        self.dimaio: dimaio.DiMaioForces | None = None
        if scene.truth.model == "dimaio":
            waist = mujoco.MjData(model)
            mujoco.mj_kinematics(model, waist)
            jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, constants.WAIST_JOINT)
            self.dimaio = dimaio.DiMaioForces(soil, scene, b.width, self.gravity, waist.xanchor[jid, :2].copy())
        self.spoil = 0.0
        # Bodies above the terrain that catch poured soil before it reaches the ground, each called as
        # ``catch(x, y, volumes, radius_m) -> (volumes still falling, volume caught)`` (a truck's bed);
        # what they catch leaves this model's account.
        self.catchers: list = []
        self._since_settle = 0.0
        self._hfield = self.grid.hfield_view(model)
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
        return float(self._load_m3[0])

    @load.setter
    def load(self, value: float) -> None:
        self._load_m3[0] = value

    @property
    def cut_force_state(self) -> float:
        """The elastic cutting force built up in the wedge ahead of the edge [N]."""
        return float(self._cut_force_n[0])

    def step(self, data: mujoco.MjData, dt: float) -> SoilContact:
        """Advance the soil by one control step of ``dt`` seconds and return its action on the bucket."""
        grid = self.grid
        if self.dimaio is not None:
            dm = self.dimaio
            dimaio.dimaio_step(grid.heights, self._grid_record, (data.xpos, data.xmat, data.xipos, data.site_xmat),
                               self._bucket_record, self._edge, dm.waist_xy, self.params, dm.params, dt, self._state,
                               dm.state, self._out, dm.out)
        else:
            self._wedge_step(data, dt)
        return self._after_step(data, dt)

    def _wedge_step(self, data: mujoco.MjData, dt: float) -> None:
        if data is not self._mj_data:  # views into MjData (they live as long as it): built once per data
            self._mj_data = data
            self._mj_arrays = (data.xpos, data.xmat, data.xipos, data.site_xmat)
        mujoco.mj_objectVelocity(self.model, data, _OBJ_BODY, self._body_id, self._vel6, 0)
        self.clear_steps += kernels.soil_step(
            self.grid.heights, self.strength, self._grid_record, self._mj_arrays, self._vel6, self._bucket_record,
            self._edge, self._surface, self._table, self.rocks, self.params, dt, self._state, self._pressure, self._out,
            self._box_body, self.early_out)

    def _after_step(self, data: mujoco.MjData, dt: float) -> SoilContact:
        grid = self.grid
        out = self._out_f8.copy()  # this step's own snapshot
        cut_volume = float(out[_CUT])
        spilled = cut_volume - float(out[_TAKEN])
        depth = out[_DEPTH]
        poured = 0.0
        if cut_volume > 0:
            w = self._window
            grid.mark(int(w[0]), int(w[1]), int(w[2]), int(w[3]))
            if spilled > 0:  # full bucket: the cut soil stays ahead of the edge, spread over the wedge
                self.spoil += self._spill_ahead(data, out, spilled)
        elif depth == 0.0 and self._load_m3[0] > 0.0:
            poured = self._pour(data, out)
        if cut_volume > 0 or poured > 0:
            window = grid.peek_dirty()
            if window is not None:
                grid.write_hfield(self._hfield, window)
        # The bucket holds up the faces it has just cut: settle only once the edge is out of the soil.
        self._since_settle += dt
        if self._since_settle >= self.scene.settle.interval_s - 1e-12 and depth == 0.0:
            self.settle_changes()
        return SoilContact(float(data.time), out, spilled, poured)

    def _spill_ahead(self, data: mujoco.MjData, out: np.ndarray, volume_m3: float) -> float:
        """Deposit ``volume_m3`` of cut soil that the full bucket cannot take over the failure wedge
        ahead of the edge, uniformly (eq. 7's assumption: the displaced soil is spread over the wedge),
        from one cell ahead of the edge to the wedge's length; returns what fell outside the box."""
        b, grid = self.bucket, self.grid
        rot = data.xmat[b.body_id].reshape(3, 3)
        edge = b.edge @ rot.T + data.xpos[b.body_id]
        length = float(out[_OUT["wedge_length_m"]])
        n_along = int(min(max(round(length / grid.cell), 1), _MAX_SPILL_ROWS))
        reach = np.linspace(grid.cell, max(length, grid.cell), n_along)
        drop = (edge[:, None, :] + reach[None, :, None] * out[_OUT["ahead"]]).reshape(-1, 3)
        return grid.deposit(drop[:, 0], drop[:, 1], np.full(len(drop), volume_m3 / len(drop)))

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
        falling = np.array([poured])
        for catch in self.catchers:  # something above the terrain takes its share first (a truck's bed)
            falling, _ = catch(lip[:1], lip[1:2], falling, b.width / 2)
        self.spoil += self.grid.deposit(lip[:1], lip[1:2], falling, radius_m=b.width / 2)
        # the load's weight in the wrench was computed before pouring
        dw = self._gamma_g * poured
        arm = rot @ b.load_centroid + org - data.xipos[b.body_id]
        if self.dimaio is not None:  # DiMaio's load acts at the centre of the cutting surface
            x_t = data.site_xmat[b.tip_site_id].reshape(3, 3)[:, 0]
            arm = out[_OUT["edge_centre_m"]] - self.dimaio.half_surface_m * x_t - data.xipos[b.body_id]
        force, torque = out[_OUT["force_n"]], out[_OUT["torque_nm"]]
        out[_OUT["load_weight_z_n"]] += dw
        force[2] += dw
        torque[0] += arm[1] * dw
        torque[1] -= arm[0] * dw
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
