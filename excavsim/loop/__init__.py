"""Wiring: the one episode driver and what runs episodes.

* :mod:`~excavsim.loop.rig`: the loop's pieces around the world (planner, executor, scanner,
  keyframes) and the moves around every dig (park, scan, go home);
* :mod:`~excavsim.loop.episode`: :class:`Episode` (stepped) and :func:`run_episode` (to the end),
  the dig-scan-plan loop (§7.2), its stopping
  rules and metrics; :mod:`~excavsim.loop.digs`: where each cycle's dig comes from (the planner
  and its fallback, random feasible digs, scripted digs); :mod:`~excavsim.loop.demo`: the demo;
* :mod:`~excavsim.loop.scenario`: episode specifications; :mod:`~excavsim.loop.campaign` (with
  :mod:`~excavsim.loop.campaign_grid` and :mod:`~excavsim.loop.campaign_report`): campaigns;
  :mod:`~excavsim.loop.regress`: the regression suite;
* :mod:`~excavsim.loop.samples`, :mod:`~excavsim.loop.collect`, :mod:`~excavsim.loop.online`,
  :mod:`~excavsim.loop.learn`: force data from digs, learning while digging, ``excavsim learn``.

The loop never imports the recorder: callers hand it in as an episode observer.
"""
