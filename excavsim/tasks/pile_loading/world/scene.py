"""The loading world: a front loader or a front shovel (models/loader, models/shovel) beside a pile lane.

The scenes ``models/<machine>/scene.xml`` include the machine and ``models/pile_box/pile_box.xml``, whose
elements carry the testbed's names (the ``soil`` hfield and geom, the ``soil_box`` body, the survey
targets and the ``scanner`` site), and each machine has the testbed's bucket names (the ``bucket`` body,
``bucket_tip`` and ``bucket_profile_*`` sites, the ``bucket_width``/``bucket_capacity`` numerics, the
``ft_force``/``ft_torque`` sensors). So the world's own soil model (:class:`~excavsim.world.soil.SoilModel`:
cutting, the wedge-model forces of eq. 8 with the truth terms, bearing and friction, filling, pouring,
settlement) and laser scanner (:class:`~excavsim.world.scanner.LaserScanner`) apply to these buckets
unchanged; this module adds only the stepping around them, for any machine whose joints are named in
:data:`MACHINE_JOINTS`.

:class:`LoadingWorld` is the facade: it writes a pile into the lane, steps MuJoCo and the soil together at
the control rate with the soil's wrench on the bucket (as :class:`~excavsim.world.simulation.Simulation`
does for the T3), and exposes the joint encoders (what the mind reads) and, as privileged truth, the
terrain and the soil volumes. The machines' servos are MuJoCo ``position`` actuators (the set-point is
the control), not the T3's flow-limited ``intvelocity`` servos: a simplification, stated in the models'
README.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import mujoco
import numpy as np
from dm_control import mjcf

from excavsim import constants
from excavsim.config import SceneConfig, SoilParams, get_soil, load_scene_config
from excavsim.errors import ConfigError, Diverged
from excavsim.readouts import element_id
from excavsim.world.soil import SoilModel, Volumes

MACHINES = ("loader", "shovel")
SCENE_XML = {m: constants.MODELS_DIR / m / "scene.xml" for m in MACHINES}
MACHINE_XML = {m: constants.MODELS_DIR / m / f"{m}.xml" for m in MACHINES}
PILE_BOX_XML = constants.MODELS_DIR / "pile_box" / "pile_box.xml"
# The machines' joints in qpos order; actuators carry the names without the suffix (Menagerie convention).
MACHINE_JOINTS = {"loader": ("travel_joint", "boom_joint", "bucket_joint"),
                  "shovel": ("base_joint", "boom_joint", "stick_joint", "bucket_joint")}
KEYFRAMES = ("carry", "dump")
CONTROL_RATE_HZ = 50.0  # the loading machines' control rate [Hz] (assumed)


def _check_machine(machine: str) -> None:
    if machine not in MACHINES:
        raise ConfigError(f"unknown loading machine {machine!r}; allowed: {', '.join(MACHINES)}")


def build_loading_scene(machine: str) -> mjcf.RootElement:
    """The MJCF element tree of ``machine``'s scene (``loader`` or ``shovel``)."""
    _check_machine(machine)
    return mjcf.from_path(str(SCENE_XML[machine]))


def build_loading_physics(machine: str) -> mjcf.Physics:
    """The compiled scene as a dm_control ``Physics``, reset to the ``carry`` keyframe."""
    physics = mjcf.Physics.from_mjcf_model(build_loading_scene(machine))
    physics.reset(keyframe_id=KEYFRAMES.index("carry"))
    return physics


def loading_scene_config(base: SceneConfig | None = None) -> SceneConfig:
    """The testbed's scene configuration (settlement, truth terms, bucket handling) with an empty lane
    (the pile is written by :meth:`LoadingWorld.set_terrain`)."""
    return (base or load_scene_config()).model_copy(update={"initial_soil_height_m": 0.0})


class LoadingWorld:
    """MuJoCo and the world's soil for a loading machine, stepped at :data:`CONTROL_RATE_HZ`.

    Args:
        machine: ``loader`` or ``shovel``.
        soil: soil parameters or a preset name of ``configs/soils.yaml`` (default the scene's).
        scene: settlement, truth terms and bucket handling (``configs/scene.yaml`` when None).
        seed: the episode seed; the soil's heterogeneity comes from it.
    """

    def __init__(self, machine: str, soil: SoilParams | str | None = None, scene: SceneConfig | None = None, *,
                 seed: int = 0):
        _check_machine(machine)
        self.machine = machine
        self.scene = loading_scene_config(scene)
        if soil is None or isinstance(soil, str):
            soil = get_soil(soil or self.scene.soil)
        self.physics = build_loading_physics(machine)
        self.model: mujoco.MjModel = self.physics.model.ptr
        self.data: mujoco.MjData = self.physics.data.ptr
        self.joints = MACHINE_JOINTS[machine]
        jids = [element_id(self.model, "joint", j) for j in self.joints]
        self._qpos = np.array([self.model.jnt_qposadr[j] for j in jids])
        self._dof = np.array([self.model.jnt_dofadr[j] for j in jids])
        self._act = np.array([element_id(self.model, "actuator", j.removesuffix("_joint")) for j in self.joints])
        self.lower = self.model.jnt_range[jids, 0].copy()
        self.upper = self.model.jnt_range[jids, 1].copy()
        self.keyframes = {k: self.model.key_qpos[element_id(self.model, "key", k)][self._qpos].copy()
                          for k in KEYFRAMES}
        self.soil = SoilModel(self.model, self.scene, soil, np.random.default_rng(seed))
        self._bucket = element_id(self.model, "body", constants.BUCKET_BODY)
        self.tip_site = element_id(self.model, "site", constants.BUCKET_TIP_SITE)
        self.substeps = max(1, int(round(1.0 / CONTROL_RATE_HZ / self.model.opt.timestep)))
        self.control_dt = self.substeps * self.model.opt.timestep
        self.width = float(self.model.numeric(constants.BUCKET_WIDTH_NUMERIC).data[0])
        self.capacity = float(self.model.numeric(constants.BUCKET_CAPACITY_NUMERIC).data[0])
        self.step_hooks: list[Callable[[LoadingWorld], None]] = []
        self.steps = 0
        self.contact = None
        self._warnings = np.array(self.data.warning.number, dtype=np.int64)

    # -- the pile --------------------------------------------------------------------------------
    def set_terrain(self, heights: np.ndarray) -> None:
        """Replace the lane's soil by ``heights`` (n_rows, n_cols) [m above the ground] and restart the volume
        account from it (bucket and spoil empty)."""
        g = self.soil.grid
        h = np.asarray(heights, dtype=float)
        if h.shape != g.heights.shape or not np.all(np.isfinite(h)) or h.min() < 0 or h.max() > g.elevation:
            raise ConfigError(f"terrain must be finite heights of shape {g.heights.shape} within "
                              f"[0, {g.elevation}] m; given shape {h.shape}")
        g.heights[...] = h
        g.take_dirty()
        self.soil.load = 0.0
        self.soil.spoil = 0.0
        self.soil.initial_volume = self.soil.volumes().total
        g.write_hfield(self.model)

    def section_heights(self, profile_x: np.ndarray, profile_z: np.ndarray) -> np.ndarray:
        """Grid heights (n_rows, n_cols) of a 2-D section (x, z) extruded across the lane (linear between points,
        zero outside)."""
        g = self.soil.grid
        xs = g.x0 + np.arange(g.heights.shape[1]) * g.cell
        z = np.interp(xs, profile_x, profile_z, left=0.0, right=0.0)
        return np.repeat(np.maximum(z, 0.0)[None, :], g.heights.shape[0], axis=0)

    # -- sensing ---------------------------------------------------------------------------------
    @property
    def time(self) -> float:
        return float(self.data.time)

    def joint_angles(self) -> np.ndarray:
        """The joint encoders (n,) in :data:`MACHINE_JOINTS` order [m or rad]."""
        return self.data.qpos[self._qpos].copy()

    def tip_pose(self) -> np.ndarray:
        """The bucket tip's (x, z, phi) in the machine's plane (privileged: for traces and tests)."""
        p = self.data.site_xpos[self.tip_site]
        x_axis = self.data.site_xmat[self.tip_site].reshape(3, 3)[:, 0]
        return np.array([p[0], p[2], math.atan2(x_axis[2], x_axis[0])])

    def volumes(self) -> Volumes:
        """Privileged truth: soil in the lane, in the bucket and in spoil (dumped outside the lane) [m^3]."""
        return self.soil.volumes()

    # -- stepping --------------------------------------------------------------------------------
    def step(self, target: np.ndarray) -> np.ndarray:
        """One control step towards the servo set-points ``target`` (n,) [m or rad]; the joint encoders after it.

        Raises:
            ExcavsimError: ``target`` is not finite or of the wrong length.
            Diverged: MuJoCo warned (its state is then reset), or the state is not finite.
        """
        t = np.asarray(target, dtype=float)
        if t.shape != self._act.shape or not np.all(np.isfinite(t)):
            raise ConfigError(f"target must be {len(self._act)} finite set-points, got {target!r}")
        d = self.data
        d.ctrl[self._act] = np.clip(t, self.lower, self.upper)
        self.contact = self.soil.step(d, self.control_dt)
        d.xfrc_applied[self._bucket, :3] = self.contact.force
        d.xfrc_applied[self._bucket, 3:] = self.contact.torque
        mujoco.mj_step(self.model, d, self.substeps)
        self.steps += 1
        counts = np.array(d.warning.number, dtype=np.int64)
        if (counts > self._warnings).any() or not np.all(np.isfinite(d.qpos)):
            self._warnings = counts
            raise Diverged(f"the loading world diverged at step {self.steps} (t = {d.time:.2f} s)")
        for hook in self.step_hooks:
            hook(self)
        return d.qpos[self._qpos].copy()

    def settle_soil(self) -> None:
        """Settle the whole terrain now (after a dig, before the scan)."""
        self.soil.settle_all()
