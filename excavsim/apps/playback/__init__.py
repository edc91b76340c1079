"""Demonstration and playback (DiMaio 1998 §6.1-6.3) on any machine of :data:`excavsim.robot.machine.MACHINES`.

:mod:`~excavsim.apps.playback.driver` demonstrates a dig in one soil and plays it back in others with each
impedance controller (``excavsim playback [--machine NAME]``); :mod:`~excavsim.apps.playback.teleop` makes a
demonstration by teleoperation from a terminal. What differs between machines is the machine's adapter
(:mod:`~excavsim.apps.playback.adapter`): :mod:`~excavsim.apps.playback.servo_arm` for joint servos and a wrist
F/T (the T3, Table 6.5's impedance), :mod:`~excavsim.apps.playback.cylinder_arm` for the excavators' cylinders
(DiMaio's TB035 and the others, Table 4.1's impedance), chosen from the machine's data by
:mod:`~excavsim.apps.playback.machines`. :mod:`~excavsim.apps.playback.figures` draws the chapter's figures.
"""

from excavsim.robot.machine import MACHINES, T3

MACHINE_NAMES = tuple(MACHINES)  # the machines the playback runs on: every machine of the machine registry
DEFAULT_MACHINE = T3.name  # the machine of `excavsim playback` without --machine: the chapter-6 experiment's
