"""excavsim.execution: the robot's executor, parameterized scripts (Rowe 1997 §4) and the dig.

- :mod:`~excavsim.execution.conditions`: what a script step waits for (joint angles, forces, time in
  the step, events, conditions held for a while), read from sensor-level data only.
- :mod:`~excavsim.execution.script`: scripts (sub-scripts of steps per joint group, with their
  watches, aborts, endings and timeouts) and the engine that ticks them.
- :mod:`~excavsim.execution.paths`: the Cartesian tip paths the executor follows.
- :mod:`~excavsim.execution.dig`: the trenching dig script (touch-down, dig, lift, dump, park) and
  :class:`~excavsim.execution.dig.DigExecutor`, which runs it through the servos and sensors
  (:class:`~excavsim.handoff.observation.Servos`), never the world itself.
"""
