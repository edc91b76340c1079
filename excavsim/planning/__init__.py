"""excavsim.planning: the trenching planner of Singh 1995 ch. 3-7, numpy only (no simulator).

One dig is chosen at a time on the scanned elevation map (never the true terrain):

* :mod:`~excavsim.planning.action`: the trenching action's geometry (§3.4): penetrate, drag and curl
  poses, the smallest reachable curl radius, the whole path of one action and the soil it sweeps;
* :mod:`~excavsim.planning.constraints`: one function per constraint (ch. 4, §5.3): shaping,
  sensible, volume, reachability, force (joint torques from predicted forces, eq. 28);
* :mod:`~excavsim.planning.feasibility`: the constraints on batches of grid cells and each cell's
  longest admissible drag d2, shared by the searches;
* :mod:`~excavsim.planning.objectives`: utility and the choice among feasible cells (§6.1.3,
  §6.2.3, eqs. 43-44);
* :mod:`~excavsim.planning.search`: :class:`~excavsim.planning.search.TrenchPlanner`, the exhaustive
  search with pruning along d1 (§6.2), and its :class:`~excavsim.planning.search.PlanResult`;
* :mod:`~excavsim.planning.anneal`: simulated annealing over the same grid (§6.3);
* :mod:`~excavsim.planning.predictor`: the nominal wedge-model force predictor (eq. 8);
* :mod:`~excavsim.planning.figures`: the feasible-set, limit and dig figures (Figs. 38-49, 87).

What only one task uses is that task's own (its folder's ``mind`` package): trenching's pre-planned
boundary-following digs when no dig is of minimum utility (§7.2), the loading planner of §3.5.
"""
