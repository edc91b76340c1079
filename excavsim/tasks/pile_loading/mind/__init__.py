"""Loading from a pile, the robot's mind: what it plans and runs from what it senses, never the truth.

* :mod:`~excavsim.tasks.pile_loading.mind.planner`: the loading action (k, alpha, d1, r) and its
  constraints, searched on a 2-D section of the scanned pile (Singh 1995 §3.5, §4.1-4.2, §7.2.1);
* :mod:`~excavsim.tasks.pile_loading.mind.script`: a planned tip path as a timed joint-space script of
  servo set-points (Rowe 1997 §4's parameterized scripts, open loop in time).

numpy only: an import-linter contract keeps every task's ``mind`` package off the world, MuJoCo,
dm_control and Rerun, as it keeps :mod:`excavsim.planning` and :mod:`excavsim.execution`.
"""
