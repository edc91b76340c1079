"""The trenching world of each machine, built by its name: the T3's soil box or an excavator's pit.

:func:`make_world` is the one place that maps a machine (:mod:`excavsim.robot.machine`) to the world that
steps it: the T3 over its soil box (:class:`~excavsim.world.simulation.Simulation`, its servos from
``configs/robot.yaml``) or a hydraulic excavator beside its pit (:class:`~excavsim.world.hydraulics.ExcavatorWorld`,
its cylinders from its :class:`~excavsim.robot.excavators.ExcavatorSpec`). Both are
:class:`~excavsim.world.facade.World` and :class:`~excavsim.handoff.observation.Servos`, so the loop
around them is the same.
"""

from __future__ import annotations

from excavsim.config import RobotConfig, SceneConfig, SoilParams
from excavsim.robot.excavators import MACHINES as EXCAVATORS
from excavsim.robot.machine import get_machine
from excavsim.world.hydraulics import ExcavatorWorld
from excavsim.world.simulation import Simulation


def make_world(machine: str, robot: RobotConfig | None = None, scene: SceneConfig | None = None, *,
               soil: SoilParams | str | None = None, seed: int = 0) -> Simulation | ExcavatorWorld:
    """The world of trenching machine ``machine`` with ``seed``.

    Args:
        machine: a name of :data:`excavsim.robot.machine.MACHINES`.
        robot: the T3's servos (``configs/robot.yaml`` when None); an excavator's are its model's.
        scene: soil preset, settlement, truth terms and bucket handling (``configs/scene.yaml`` when None);
            an excavator's pit starts filled flush with the ground (its ``initial_soil_height_m`` is the pit's).
        soil: the soil's parameters or a preset name instead of the scene's ``soil`` preset (e.g. a preset
            with its terms scaled, as the playback's stiffer and softer soils).

    Raises:
        ConfigError: ``machine`` is unknown (the message lists the allowed ones).
    """
    get_machine(machine)  # raises with the allowed names
    if machine in EXCAVATORS:
        if soil is None and scene is not None:
            soil = scene.soil
        return ExcavatorWorld(machine, soil, scene, seed=seed)
    return Simulation(robot, scene, soil, seed=seed)
