"""Rowe's mass-excavation script (Rowe 1997 §4.2-4.3, §6.2), one for every machine.

A load's cycle after the dig (swing to the truck, dump, swing back) is one parameterized script of four
coupled single-joint sub-scripts, its numbers computed for each load and some of them tuned online. What
differs between machines is data or a small strategy object, not another script:

- :mod:`~excavsim.execution.rowe_script.listing`: the script (§6.2's listing, Fig. 4) and
  :class:`~excavsim.execution.rowe_script.listing.ScriptJoints`, a machine's joint names;
- :mod:`~excavsim.execution.rowe_script.params`: every number of the script
  (:class:`~excavsim.execution.rowe_script.params.RoweParams`), a machine's heuristics
  (:class:`~excavsim.execution.rowe_script.params.ScriptRules`) and
  :func:`~excavsim.execution.rowe_script.params.compute_params` (§4.2);
- :mod:`~excavsim.execution.rowe_script.geometry`: the truck
  (:class:`~excavsim.execution.rowe_script.geometry.TruckSite`), the clearance angle of Fig. 3 and the dump
  rules (the T3's dump at a height, the 25 t's lowest dump clear of the side);
- :mod:`~excavsim.execution.rowe_script.timing`: the machine models the triggers come from (the T3's
  :class:`~excavsim.execution.rowe_script.timing.TimingModel`, the 25 t's swing profile);
- :mod:`~excavsim.execution.rowe_script.runner`: the script run on any machine's servos.

The dig before it is the machine's own: the T3's fixed dig of §6.2
(:func:`~excavsim.execution.paths.follow_path`), the 25 t's AutoDig of §4.4 (the mind side of the task that loads
a truck with it).
"""
