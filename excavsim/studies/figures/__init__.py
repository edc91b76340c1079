"""The thesis' figures by command (``excavsim figures``).

:mod:`~excavsim.studies.figures.thesis` lists and draws them, :mod:`~excavsim.studies.figures.plan` draws
the planner's, and :mod:`~excavsim.studies.figures.drags` drives the bucket along prescribed paths
through the world's soil (the soil-bin experiments the soil figures need).
"""
