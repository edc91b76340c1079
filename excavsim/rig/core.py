"""The loop's pieces around the world, and the moves every episode makes: park, go home, scan.

:func:`make_rig` builds what a loop needs besides the :class:`~excavsim.world.simulation.Simulation`:
the configurations, the robot's model of itself (:class:`~excavsim.robot.kinematics.PlanarArm`,
read from the compiled model), the scanner, the planner with its nominal force predictor, the dig
executor and the model's ``home`` and ``park`` keyframes. :func:`park`, :func:`go_home` and
:func:`scan` are the moves around each dig (Singh 1995 §7.2, Fig. 107): park out of
the scanner's view, scan ten images into a map, come back over the box.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable

import numpy as np

from excavsim import constants
from excavsim.config import (ExecutorConfig, PlannerConfig, SensingConfig, SoilParams, TrenchGoal, get_soil,
                             load_executor_config, load_planner_config, load_sensing_config, load_trench_goal)
from excavsim.execution.dig import DigExecutor
from excavsim.execution.droop import DroopCompensation
from excavsim.handoff.dig import ExecutionRecord
from excavsim.handoff.maps import ElevationMap
from excavsim.planning.constraints import PoseTorqueLimits
from excavsim.planning.predictor import WedgePredictor
from excavsim.planning.search import TrenchPlanner
from excavsim.robot.extract import arm_from_model
from excavsim.readouts import keyframe_qpos
from excavsim.robot.kinematics import PlanarArm
from excavsim.robot.machine import T3, Machine
from excavsim.robot.reachability import TableSpec, load_or_build
from excavsim.sensing.elevation import MapAccuracy, map_accuracy, scan_map
from excavsim.sensing.ft import ForceSensor
from excavsim.sensing.pressure import CylinderForceReading
from excavsim.world.scanner import LaserScanner
from excavsim.world.simulation import Simulation


@dataclasses.dataclass
class Rig:
    """Everything a loop needs around the Simulation: configurations, the robot's model of itself,
    the scanner, the planner with its nominal force predictor, the executor and the keyframes.

    Attributes:
        home, park: joint angles of the ``home`` (over the box) and ``park`` (out of the scanner's view)
            poses in the machine's joint order [rad]: the model's keyframes, or the machine's own.
        width, capacity: the bucket's width [m] and struck capacity [m^3], from the model.
        machine: the machine's description (its joints, planar chain, poses and torque limits).
    """

    goal: TrenchGoal
    planner_cfg: PlannerConfig
    executor_cfg: ExecutorConfig
    sensing_cfg: SensingConfig
    arm: PlanarArm
    scanner: LaserScanner
    planner: TrenchPlanner
    executor: DigExecutor
    width: float
    capacity: float
    home: np.ndarray
    park: np.ndarray
    machine: Machine = T3
    # Table 7's timing hooks (read by excavsim.tasks.trench.timing.Table7Timer; nothing else reads them): the
    # last scan's wall seconds of range acquisition and of map building, the last moves' simulated
    # and wall seconds (the dig tool's set-up).
    timings: dict[str, float] = dataclasses.field(default_factory=dict)


def make_rig(sim: Simulation, *, seed: int = 0, goal: TrenchGoal | None = None,
             planner_cfg: PlannerConfig | None = None, executor_cfg: ExecutorConfig | None = None,
             sensing_cfg: SensingConfig | None = None, machine: Machine = T3) -> Rig:
    """Build the loop's pieces with the defaults from ``configs/`` where none are given.

    Args:
        sim: the world (the T3's :class:`Simulation`, or an excavator's
            :class:`~excavsim.world.hydraulics.ExcavatorWorld`).
        seed: the episode seed; the scanner's noise and drift come from it.
        goal: the trench (default ``configs/trenches/straight.yaml``).
        machine: the machine ``sim`` steps (default the T3): its planar chain is read from the model with
            its joint names, its reachability table covers its reach, the planner's torque limits are its
            (:func:`planner_limits`), and the executor runs on its joints.
    """
    goal = goal or load_trench_goal(constants.TRENCHES_DIR / "straight.yaml")
    planner_cfg = planner_cfg or load_planner_config()
    sensing_cfg = sensing_cfg or load_sensing_config()
    executor_cfg = executor_cfg or load_executor_config()
    arm = arm_from_model(sim.model, joints=machine.chain_joints)
    scanner = LaserScanner(sim.model, sim.soil.grid, sensing_cfg.scanner, np.random.default_rng((seed, 7)))
    nominal = get_soil(sim.scene.soil)
    width = float(sim.model.numeric(constants.BUCKET_WIDTH_NUMERIC).data[0])
    capacity = float(sim.model.numeric(constants.BUCKET_CAPACITY_NUMERIC).data[0])
    planner = make_planner(arm, planner_limits(sim, machine), width, capacity, goal, planner_cfg, nominal,
                           table_spec=machine.table)
    home, park_q = (np.asarray(p, dtype=float) if p is not None else keyframe_qpos(sim.model, key, machine.joints)
                    for p, key in ((machine.home, "home"), (machine.park, "park")))
    ft = (CylinderForceReading(arm, machine, rate_hz=sensing_cfg.force_sensor.rate_hz)
          if machine.force_reading == "cylinders"
          else ForceSensor.from_config(sim.model, sensing_cfg.force_sensor, joints=machine.joints))
    # an excavator's cylinders droop under the arm's weight: its servos get the droop fed forward
    servos = DroopCompensation(sim, arm, machine) if machine.hydraulics is not None else sim
    executor = DigExecutor(servos, arm, executor_cfg, ft, park_q, machine=machine)
    return Rig(goal, planner_cfg, executor_cfg, sensing_cfg, arm, scanner, planner, executor, width, capacity,
               home, park_q, machine)


def planner_limits(sim: Simulation, machine: Machine = T3) -> np.ndarray | PoseTorqueLimits:
    """The planar joints' torque limits the planner's force constraint holds the predicted torques to
    (Singh 1995 §5.3.3): the T3's relief torques, constants of its model's actuators; for a machine with
    cylinders, Singh's joint-torque limits become the relief pressure x the piston (pushing) or annulus
    (pulling) area x the moment arm ``dL/dq``, which varies with the pose
    (:meth:`~excavsim.robot.machine.Machine.torque_limits`): a
    :class:`~excavsim.planning.constraints.PoseTorqueLimits` that the force constraint evaluates at each
    sample's joint angles, in the direction of each predicted torque."""
    if machine.hydraulics is None:
        return sim.torque_limit[1:4]
    return PoseTorqueLimits(machine.torque_limits, machine.hydraulics.planner_torque_limits())


def make_planner(arm: PlanarArm, torque_limits: np.ndarray, width: float, capacity: float, goal: TrenchGoal,
                 planner_cfg: PlannerConfig, soil: SoilParams, table=None, table_spec: TableSpec = TableSpec()
                 ) -> TrenchPlanner:
    """The trenching planner with its nominal force predictor (the static wedge model of ``soil``).

    Args:
        arm: the robot's model of itself.
        torque_limits: (3,) shoulder, elbow and wrist pitch torque limits [N m].
        width, capacity: the bucket's width [m] and struck capacity [m^3].
        goal: the trench.
        planner_cfg: the planner's configuration.
        soil: the soil the predictor assumes.
        table: the arm's reachability table (default: loaded from the cache, or built to ``table_spec``).
    """
    table = load_or_build(arm, table_spec) if table is None else table
    return TrenchPlanner(arm, table, torque_limits, width, capacity, goal, planner_cfg,
                         WedgePredictor(soil, width, capacity_m3=planner_cfg.heaped_capacity_factor * capacity),
                         soil.density_kg_m3)


def go_to(sim: Simulation, q: np.ndarray, cfg: ExecutorConfig) -> None:
    """A joint move to ``q`` (6,) [rad] until every joint is within ``settle_tol_rad``, or
    ``move_timeout_s``. Home and park both hold the bucket high, so a straight joint move between
    them clears the walls."""
    for _ in range(int(cfg.move_timeout_s / sim.control_dt)):
        if np.all(np.abs(sim.track(q).q - q) <= cfg.settle_tol_rad):
            break


def _timed_move(sim: Simulation, rig: Rig, q: np.ndarray, name: str) -> None:
    """:func:`go_to` ``q``, its simulated and wall seconds kept in ``rig.timings[name + "_sim_s"/"_wall_s"]``."""
    t_sim, t_wall = sim.time, time.perf_counter()
    go_to(rig.executor.sim, q, rig.executor_cfg)  # the executor's servos: the world's, or fed forward
    rig.timings[name + "_sim_s"] = float(sim.time - t_sim)
    rig.timings[name + "_wall_s"] = time.perf_counter() - t_wall


def park(sim: Simulation, rig: Rig) -> None:
    """Swing the arm out of the scanner's view (the ``park`` keyframe)."""
    _timed_move(sim, rig, rig.park, "park")


def go_home(sim: Simulation, rig: Rig) -> None:
    """Bring the arm back over the box (the ``home`` keyframe), ready for a dig."""
    _timed_move(sim, rig, rig.home, "home")


def scan(sim: Simulation, rig: Rig) -> tuple[ElevationMap, MapAccuracy]:
    """Scan ``n_scans`` range images, build the elevation map, and its accuracy against the truth
    (privileged, for logs and metrics; the map is all the mind gets)."""
    emap, cals = scan_map(rig.scanner, sim.time, rig.sensing_cfg.map, timings=rig.timings)
    return emap, map_accuracy(emap, sim.soil.grid.surface_z, cals)


def bucket_witness(sim: Simulation) -> Callable[[str, ExecutionRecord], None]:
    """The executor's ``on_phase`` hook that writes the soil in the bucket at lift-out (privileged
    truth, for metrics) into the record: the loop measures the world where the executor says the
    dig is; the executor itself never reads it. A dig that found no contact carries what the bucket
    held then (nothing)."""

    def witness(phase: str, rec: ExecutionRecord) -> None:
        if phase in ("lift out", "no contact"):
            rec.bucket_volume_m3 = float(sim.truth.volumes.bucket)

    return witness
