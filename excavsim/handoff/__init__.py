"""What passes between the boxes of the pipeline: plain values and protocols, numpy only.

The contracts at the bottom of the package, imported by every box and importing none of them:

* :mod:`~excavsim.handoff.maps`: what the scanner returns (:class:`RangeImage`, :class:`ScanGeometry`)
  and the elevation map the planner reads (:class:`ElevationMap`);
* :mod:`~excavsim.handoff.goal`: the trench goal's profile and the mapped surface along the arm plane;
* :mod:`~excavsim.handoff.forces`: the :class:`ForcePredictor` protocol and the :class:`DigContext`
  of each query;
* :mod:`~excavsim.handoff.dig`: the trenching action, the dig chosen for a cycle, the plan the
  executor follows and its record;
* :mod:`~excavsim.handoff.observation`: the sensor-level :class:`Observation` and the
  :class:`Servos` interface the executor drives;
* :mod:`~excavsim.handoff.episode`: the observer hooks of an episode and its results.
"""
