"""excavsim.learning: learning to predict resistive forces (Singh 1995 §5.2).

* :mod:`~excavsim.learning.encoding`, :mod:`~excavsim.learning.dataset`: force samples of executed
  digs (action, progress, terrain before the dig, measured F/T), saved as a table;
* :mod:`~excavsim.learning.bases`: the naive, mechanics-based and reduced bases (eqs. 15-17);
* :mod:`~excavsim.learning.predictors`: the methods behind one interface (wedge fit, global
  regression batch and recursive, nearest neighbours, LWR, back-propagation net);
* :mod:`~excavsim.learning.evaluate`, :mod:`~excavsim.learning.figures`: Tables 4 and 5, Fig. 81;
* :mod:`~excavsim.learning.adapter`: a learned model as the planner's force predictor.

This package is numpy, scipy and scikit-learn on arrays (no simulator, no recorder). What drives
the simulator lives in :mod:`excavsim.loop`: :mod:`~excavsim.rig.samples` (force samples from an
episode's digs), :mod:`~excavsim.studies.learning.collect` (digging for data), :mod:`~excavsim.rig.online`
(the episode observer that learns while digging) and :mod:`~excavsim.studies.learning.compare` (the
``excavsim learn`` study).
"""
