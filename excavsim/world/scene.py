"""Compose the testbed scene with dm_control.mjcf and apply the configuration.

The Menagerie-style ``models/t3/scene.xml`` includes the arm (``t3.xml``) and the soil box
(``soil_box.xml``). :func:`build_scene` loads it with PyMJCF and applies, on top of the files'
defaults, the soil grid resolution (``configs/scene.yaml``) and the hydraulic servo limits and gains
(``configs/robot.yaml``); :func:`build_physics` compiles it into a dm_control ``Physics`` for named
access (``physics.named.data.qpos['shoulder_joint']``).
"""

from __future__ import annotations

import numpy as np
from dm_control import mjcf

from excavsim import constants
from excavsim.config import RobotConfig, SceneConfig, load_robot_config, load_scene_config
from excavsim.errors import ModelError


def _find(root: mjcf.RootElement, namespace: str, name: str):
    element = root.find(namespace, name)
    if element is None:
        available = sorted(e.name for e in root.find_all(namespace) if e.name)
        raise ModelError(f"{namespace} {name!r} not found in {root.model!r}. Available: {available}")
    return element


def apply_robot_config(root: mjcf.RootElement, robot: RobotConfig) -> None:
    """Write servo limits and gains from ``robot`` into the actuators of ``root`` (in place)."""
    for name, servo in robot.joints.by_actuator().items():
        act = _find(root, "actuator", name)
        act.kp = servo.kp_nm_per_rad
        act.kv = servo.kv_nm_s_per_rad
        vmax = servo.velocity_limit_rad_s
        act.ctrlrange = np.array([-vmax, vmax])
        act.forcerange = np.array([-servo.torque_limit_nm, servo.torque_limit_nm])


def apply_scene_config(root: mjcf.RootElement, scene: SceneConfig) -> None:
    """Set the soil heightfield resolution from ``scene`` (in place)."""
    hfield = _find(root, "hfield", constants.SOIL_HFIELD)
    hfield.nrow = scene.soil_grid_samples
    hfield.ncol = scene.soil_grid_samples


def build_scene(robot: RobotConfig | None = None, scene: SceneConfig | None = None) -> mjcf.RootElement:
    """The testbed scene as an MJCF element tree with the configuration applied.

    Args:
        robot: servo configuration; ``configs/robot.yaml`` when None.
        scene: scene configuration; ``configs/scene.yaml`` when None.

    Returns:
        The PyMJCF root, ready for :func:`build_physics` or further composition.
    """
    root = mjcf.from_path(str(constants.SCENE_XML))
    apply_robot_config(root, robot or load_robot_config())
    apply_scene_config(root, scene or load_scene_config())
    return root


def build_physics(robot: RobotConfig | None = None, scene: SceneConfig | None = None) -> mjcf.Physics:
    """Compile the configured scene into a dm_control ``Physics``, reset to the ``home`` keyframe."""
    physics = mjcf.Physics.from_mjcf_model(build_scene(robot, scene))
    physics.reset(keyframe_id=constants.KEYFRAMES.index("home"))
    return physics
