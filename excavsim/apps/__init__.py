"""Applications: programs a user runs that are neither a task of the loop nor a study of many runs.

:mod:`~excavsim.apps.playback` demonstrates a dig and plays it back on any machine (DiMaio 1998 ch. 6,
with teleoperation to make demonstrations); :mod:`~excavsim.apps.calibrate` fits a soil to force
records and re-runs the digs. No application imports another (an import-linter contract).
"""
