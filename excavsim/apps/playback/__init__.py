"""Demonstration and playback (DiMaio 1998 §6.1-6.3).

:mod:`~excavsim.apps.playback.play` demonstrates a dig in one soil and plays it back in others with each
impedance controller; :mod:`~excavsim.apps.playback.teleop` makes a demonstration by teleoperation from
a terminal; :mod:`~excavsim.apps.playback.excavator` runs both on DiMaio's TB035 mini-excavator with
Table 4.1's impedance (``excavsim playback --machine tb035``).
"""
