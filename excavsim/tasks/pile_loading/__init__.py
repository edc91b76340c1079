"""Loading from a pile: the 2-D simulation and the MuJoCo one (Singh 1995 §7.2.1).

:mod:`~excavsim.tasks.pile_loading.planar` is the 2-D simulation, :mod:`~excavsim.tasks.pile_loading.task` the
MuJoCo episode with the front loader or the front shovel. The mind-side pieces (the loading planner)
stay in :mod:`excavsim.planning` so that the truth/belief contracts cover them.
"""
