"""The digging rig: a machine with its planar digging chain, and the mind's pieces that dig with it.

What every driver of a digging arm needs around the world (the T3 or a hydraulic excavator), whatever
it is asked to do: the trenching task, the calibration's digs, teleoperation and playback, the
joint-level environments and the thesis' figures all stand on it.

* :mod:`~excavsim.rig.core`: :func:`~excavsim.rig.core.make_rig` (the robot's model of itself read from
  the compiled model, the scanner, the planner with its nominal force predictor, the dig executor and the
  home and park poses) and the moves around a dig (park out of the scanner's view, scan, go home);
* :mod:`~excavsim.rig.measures`: the privileged measures of a trench goal on the true terrain;
* :mod:`~excavsim.rig.samples`: force samples from the digs; :mod:`~excavsim.rig.online`: the planner's
  force model learned online from them (Singh 1995 §5.2).

It wires the world to the mind as the loop does, below the loop and the tasks (the layers of
``pyproject.toml``); it names no task.
"""
