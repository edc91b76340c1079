"""Which adapter a machine of the machine registry gets for the playback, from its data.

:func:`adapter_for` is the one place that maps a machine (:data:`excavsim.robot.machine.MACHINES`) to its
:class:`~excavsim.apps.playback.adapter.MachineAdapter`: a machine with cylinders
(:attr:`~excavsim.robot.machine.Machine.hydraulics`) gets a
:class:`~excavsim.apps.playback.cylinder_arm.CylinderArm`, one with joint servos a
:class:`~excavsim.apps.playback.servo_arm.ServoArm`. No machine is named here.
"""

from __future__ import annotations

from excavsim.apps.playback import DEFAULT_MACHINE
from excavsim.apps.playback.adapter import MachineAdapter
from excavsim.apps.playback.cylinder_arm import CylinderArm
from excavsim.apps.playback.servo_arm import ServoArm
from excavsim.robot.machine import get_machine


def adapter_for(machine: str = DEFAULT_MACHINE) -> MachineAdapter:
    """The playback's side of ``machine`` (see the module docstring).

    Raises:
        ConfigError: no such machine; the message lists the allowed ones.
    """
    m = get_machine(machine)
    return CylinderArm(m) if m.hydraulics is not None else ServoArm(m)
