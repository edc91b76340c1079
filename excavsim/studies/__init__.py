"""Studies: many runs of the platform, compared and summarised.

Campaigns, the regression suite, the thesis' experiments, its figures, the learning comparison and
the benchmarks. Each study stands on :mod:`excavsim.loop` and no study imports another (an
import-linter contract): :mod:`~excavsim.studies.campaign`, :mod:`~excavsim.studies.regress`,
:mod:`~excavsim.studies.experiment`, :mod:`~excavsim.studies.figures`, :mod:`~excavsim.studies.learning`,
:mod:`~excavsim.studies.bench`.
"""
