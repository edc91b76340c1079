"""The planner regression suite (``excavsim regress``): golden scenarios over several seeds, judged statistically.

:mod:`~excavsim.studies.regress.suite` runs and judges it, :mod:`~excavsim.studies.regress.stats` holds the
statistics, :mod:`~excavsim.studies.regress.against` runs the same episodes with another git commit.
"""
