"""Soil-bin experiments on the world's soil model: the bucket driven along prescribed tip paths.

The thesis measured the wedge model's phenomena by making the bucket follow a prescribed
trajectory through the testbed's sand and recording the force sensor (Singh 1995
§5.1.3, Figs. 54, 58-63; Fig. 20 for the penetration). :class:`KinematicDrive` does the same to the
world (truth): it sets the arm's joints from inverse kinematics for each tip pose, their velocities
by finite difference, runs MuJoCo's kinematics and steps only the soil model, so that the measured
force is the soil's alone (no servo lag, no arm dynamics). Simplification: the force read is the
soil's wrench on the bucket (cutting, bearing, friction, rocks) without the load's weight, in place
of the thesis' F/T sensor, which also saw the bucket's weight and inertia (§7.1.3).

This is privileged truth, for figures and tests: the loop wires world and mind, and nothing of the
robot's mind reads these records.
"""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np

from excavsim import constants
from excavsim.config import SceneConfig, load_scene_config
from excavsim.errors import ConfigError, GoalError
from excavsim.robot.extract import arm_from_model
from excavsim.world.simulation import Simulation

SURFACE_Z_M = 0.5  # configs/scene.yaml's initial fill, where every experiment starts [m]
ENTRY_CLEARANCE_RAD = math.radians(10.0)  # epsilon of §3.4: the rake exceeds the approach by this


@dataclasses.dataclass(frozen=True)
class DragRecord:
    """One prescribed motion through the soil, one row per control step.

    Attributes:
        s_m: (n,) distance the tip has travelled along the commanded path [m].
        depth_m: (n,) mean depth of the cutting edge below the surface ahead of it [m].
        rake_rad: (n,) rake of the blade [rad].
        speed_m_s: (n,) speed of the edge into the soil [m/s].
        force_plane_n: (n, 2) soil force on the bucket in the arm plane (X radial, Z up) [N].
        force_tip_n: (n, 2) the same force in the tip frame (x along the blade towards the edge, z the
            face normal into the bucket; Fig. 18, Fig. 103) [N].
        cut_m3: (n,) soil cut so far [m^3].
        poses: (n, 3) commanded tip poses (x, z, pitch) [m, m, rad].
    """

    s_m: np.ndarray
    depth_m: np.ndarray
    rake_rad: np.ndarray
    speed_m_s: np.ndarray
    force_plane_n: np.ndarray
    force_tip_n: np.ndarray
    cut_m3: np.ndarray
    poses: np.ndarray

    @property
    def magnitude_n(self) -> np.ndarray:
        """(n,) magnitude of the soil force [N]."""
        return np.linalg.norm(self.force_plane_n, axis=1)

    def where(self, mask: np.ndarray) -> DragRecord:
        """The rows selected by ``mask``."""
        return DragRecord(*(getattr(self, f.name)[mask] for f in dataclasses.fields(self)))


def scene_with_truth(**truth) -> SceneConfig:
    """The default scene (configs/scene.yaml) with some of its truth terms replaced, e.g.
    ``scene_with_truth(heterogeneity_std=0.0)``; the soil model itself is untouched."""
    base = load_scene_config()
    bad = sorted(set(truth) - set(type(base.truth).model_fields))
    if bad:
        raise ConfigError(f"unknown truth term(s) {bad}; allowed: {sorted(type(base.truth).model_fields)}")
    return base.model_copy(update={"truth": base.truth.model_copy(update=truth)})


class KinematicDrive:
    """Moves the arm kinematically along tip poses and steps only the world's soil model.

    Args:
        sim: a fresh world (its soil flat at the scene's fill height).
    """

    def __init__(self, sim: Simulation):
        self.sim = sim
        self.arm = arm_from_model(sim.model)
        self._q_prev: np.ndarray | None = None
        self._tip = sim.model.site(constants.BUCKET_TIP_SITE).id
        self._rows: list[tuple] = []
        self._s = 0.0
        self._cut = 0.0
        self._last: np.ndarray | None = None

    def place(self, pose) -> None:
        """Put the tip at ``pose`` (x, z, pitch) in the arm plane (waist at 0) for one control step.

        Raises:
            ExcavsimError: the pose is out of the arm's reach.
        """
        m, d = self.sim.model, self.sim.data
        pose = np.asarray(pose, float)
        q3, ok = self.arm.inverse(pose)
        if not ok:
            raise GoalError(f"tip pose {np.round(pose, 3).tolist()} (x, z [m], pitch [rad]) is out of the "
                            "T3's reach; allowed: a pose inside the workspace over the soil box")
        q = np.r_[0.0, q3, 0.0, 0.0]
        dt = self.sim.control_dt
        d.qpos[:6] = q
        d.qvel[:6] = 0.0 if self._q_prev is None else (q - self._q_prev) / dt
        self._q_prev = q
        mujoco.mj_forward(m, d)
        d.time += dt
        c = self.sim.soil.step(d, dt)
        if self._last is not None:
            self._s += float(np.linalg.norm(pose[:2] - self._last[:2]))
        self._last = pose
        self._cut += c.cut_volume_m3
        force = np.asarray(c.force - c.load_weight)
        rot = d.site_xmat[self._tip].reshape(3, 3)
        self._rows.append((self._s, c.depth_m, c.rake_rad, c.cutting_speed_m_s, force[0], force[2],
                           float(force @ rot[:, 0]), float(force @ rot[:, 2]), self._cut, *pose))

    def line(self, start, end, speed_m_s: float) -> None:
        """Move the tip in a straight line (pitch interpolated) at ``speed_m_s``."""
        start, end = np.asarray(start, float), np.asarray(end, float)
        n = max(1, int(np.ceil(np.linalg.norm(end[:2] - start[:2]) / speed_m_s / self.sim.control_dt)))
        for i in range(n + 1):
            self.place(start + (end - start) * (i / n))

    def follow(self, poses: np.ndarray, speed_m_s: float) -> None:
        """Move the tip through ``poses`` (n, 3), each segment at ``speed_m_s``."""
        poses = np.asarray(poses, float)
        for a, b in zip(poses[:-1], poses[1:]):
            self.line(a, b, speed_m_s)

    def record(self, *, from_row: int = 0) -> DragRecord:
        """What was measured from row ``from_row`` on, distances counted from there."""
        a = np.asarray(self._rows[from_row:], float).reshape(-1, 12)
        if len(a):
            a[:, 0] -= a[0, 0]  # distances from the first row returned
        return DragRecord(a[:, 0], a[:, 1], a[:, 2], a[:, 3], a[:, 4:6], a[:, 6:8], a[:, 8], a[:, 9:12])

    @property
    def rows(self) -> int:
        """Control steps driven so far."""
        return len(self._rows)


def horizontal_drag(sim: Simulation, *, x0_m: float, length_m: float, depth_m: float, rake_rad: float,
                    speed_m_s: float = 0.1, lower_speed_m_s: float = 0.1) -> DragRecord:
    """Enter the flat surface at ``x0_m`` and go down to ``depth_m`` along the approach angle
    ``rake - epsilon`` (epsilon = 10 deg, the clearance of the thesis' penetrate, §3.4, Fig. 19),
    then drag the edge horizontally towards the robot for ``length_m`` at a constant rake (Fig. 58).
    Returns the drag only (the entry is driven, not returned).

    The entry keeps the bucket's bottom in the slot its edge cuts. A vertical entry, as this
    function drove before, pushed the heel behind the edge into uncut soil at its bearing capacity
    (1.8 kN at 10 cm, 7.6 kN at 20 cm), a transient the drag then carried for 10-20 cm; the
    approach is at least 5 deg below the horizontal.
    """
    z = SURFACE_Z_M - depth_m
    alpha = max(rake_rad - ENTRY_CLEARANCE_RAD, math.radians(5.0))
    drive = KinematicDrive(sim)
    bottom = (x0_m - depth_m / math.tan(alpha), z, rake_rad)
    above = (x0_m + 0.03 / math.tan(alpha), SURFACE_Z_M + 0.03, rake_rad)
    drive.place(above)
    drive.line(above, bottom, lower_speed_m_s)
    start = drive.rows
    drive.line(bottom, (bottom[0] - length_m, z, rake_rad), speed_m_s)
    return drive.record(from_row=start)


def inclined_penetration(sim: Simulation, *, x0_m: float, length_m: float, alpha_rad: float, rake_rad: float,
                         speed_m_s: float = 0.1) -> DragRecord:
    """Enter the flat surface at ``x0_m`` and move in a straight line at ``alpha_rad`` below the
    horizontal, towards the robot, for ``length_m`` at a constant rake (Figs. 20, 60-61, 63)."""
    drive = KinematicDrive(sim)
    entry = np.array([x0_m, SURFACE_Z_M, rake_rad])
    above = entry + [0.05 * math.cos(alpha_rad), 0.05 * math.sin(alpha_rad), 0.0]
    drive.place(above)
    drive.line(above, entry, speed_m_s)
    start = drive.rows
    end = entry - [length_m * math.cos(alpha_rad), length_m * math.sin(alpha_rad), 0.0]
    drive.line(entry, end, speed_m_s)
    return drive.record(from_row=start)


def moving_average(x: np.ndarray, n: int) -> np.ndarray:
    """``n``-point centred moving average (Fig. 54: "smoothed with a 9 point moving average"); the
    ends average over the samples available."""
    x = np.asarray(x, float)
    if n <= 1 or x.size == 0:
        return x.copy()
    k = np.ones(n)
    return np.convolve(x, k, mode="same") / np.convolve(np.ones_like(x), k, mode="same")
