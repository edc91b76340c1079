"""The learning comparison (``excavsim learn``, Singh 1995 §5.2).

:mod:`~excavsim.studies.learning.collect` digs in the simulator for force data,
:mod:`~excavsim.studies.learning.compare` cross-validates the predictors and runs the
nominal-versus-learned campaign. Learning while digging (the episode observer) is the platform's:
:mod:`excavsim.rig.online`.
"""
