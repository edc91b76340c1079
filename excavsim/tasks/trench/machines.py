"""A trenching machine's own numbers for the mind: ``configs/machines/<machine>.yaml``.

The planner's grid and rules and the dig script's numbers in ``configs/planner.yaml`` and
``configs/executor.yaml`` are the T3's (its 3 m soil box, its 0.3 m bucket, its servos). Another machine
digs another pit with another bucket: its file holds what differs, as overrides merged over those files
(an episode specification's own ``planner:`` and ``executor:`` overrides go on top). The T3 has no file.
The trench goals a machine digs by name are in ``configs/trenches/<machine>/`` (the T3's in
``configs/trenches/``), in the coordinates of its own pit.
"""

from __future__ import annotations

import pathlib
from typing import Any

from pydantic import Field

from excavsim import constants
from excavsim.config.loader import StrictModel, load_config

MACHINES_DIR = constants.CONFIGS_DIR / "machines"


class MachineConfig(StrictModel):
    """What a machine changes in the mind's configuration files (see the module docstring)."""

    planner: dict[str, Any] = Field(default_factory=dict, description="overrides of configs/planner.yaml")
    executor: dict[str, Any] = Field(default_factory=dict, description="overrides of configs/executor.yaml")
    sensing: dict[str, Any] = Field(default_factory=dict, description="overrides of configs/sensing.yaml")


def machine_config_path(machine: str) -> pathlib.Path:
    """``configs/machines/<machine>.yaml`` (it may not exist: the T3 has none)."""
    return MACHINES_DIR / f"{machine}.yaml"


def load_machine_config(machine: str) -> MachineConfig:
    """The machine's overrides (none when it has no file)."""
    path = machine_config_path(machine)
    return load_config(path, MachineConfig) if path.is_file() else MachineConfig()


def machine_trenches_dir(machine: str) -> pathlib.Path:
    """Where the trench goals of ``machine`` are named: ``configs/trenches/`` for the T3, else
    ``configs/trenches/<machine>/`` (each machine's goals are in its own pit's coordinates)."""
    return constants.TRENCHES_DIR if machine == "t3" else constants.TRENCHES_DIR / machine


def machine_pit_xml(machine: str) -> pathlib.Path:
    """The MJCF holding the soil box ``machine`` digs: the T3's ``models/soil_box/soil_box.xml``, else the pit
    of ``models/<machine>/scene.xml``."""
    return constants.SOIL_BOX_XML if machine == "t3" else constants.MODELS_DIR / machine / "scene.xml"


def machine_box(machine: str):
    """The inside and floor of the soil ``machine`` digs (:class:`~excavsim.config.semantic.SoilBox`)."""
    from excavsim.config.semantic import soil_box

    return soil_box(machine_pit_xml(machine))


def machine_scene(scene, machine: str):
    """``scene`` as ``machine``'s world uses it: the T3's box holds ``initial_soil_height_m`` of soil; an
    excavator's pit starts filled flush with the ground (its depth, as
    :class:`~excavsim.world.hydraulics.ExcavatorWorld` fills it)."""
    if machine == "t3":
        return scene
    return scene.model_copy(update={"initial_soil_height_m": -machine_box(machine).floor_z})
