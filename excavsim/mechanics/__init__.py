"""Soil mechanics shared by the world (truth) and the robot's mind (its force predictors): numpy only.

* :mod:`~excavsim.mechanics.wedge`: the wedge model of a blade cutting soil, the Fundamental
  Equation of Earthmoving (Singh 1995 §5.1.2, eqs. 3-11), and ``G_M_S2``;
* :mod:`~excavsim.mechanics.bearing`: strip-footing bearing factors (standard geotechnics).

The world's soil model adds to these what the static model misses (speed, saw-tooth failure,
heterogeneity, rocks); the planner's nominal predictor uses them as they are.
"""
