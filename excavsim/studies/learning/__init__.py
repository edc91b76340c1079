"""The learning comparison (``excavsim learn``, 000_a3ca905d8c6d92bf.txt §5.2).

:mod:`~excavsim.studies.learning.collect` digs in the simulator for force data,
:mod:`~excavsim.studies.learning.compare` cross-validates the predictors and runs the
nominal-versus-learned campaign. Learning while digging (the episode observer) is the platform's:
:mod:`excavsim.loop.online`.
"""
