"""The robot's senses, as its mind reads them: range images to elevation maps, and the wrist F/T sensor.

* :mod:`~excavsim.sensing.elevation`: calibration against surveyed targets, the median over scans,
  binning into the elevation map, filling unobserved cells (Singh 1995 §7.1.2), and
  the map's accuracy against the truth (for logs and tests);
* :mod:`~excavsim.sensing.ft`: the F/T reading at the bucket tip from the wrist sensor (§7.1.3).

The scanner that casts rays at the true terrain is the world's
(:class:`~excavsim.world.scanner.LaserScanner`); what passes between them are the values of
:mod:`excavsim.handoff.maps`.
"""
