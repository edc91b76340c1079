"""The platform: the one episode driver and what every episode needs.

* :mod:`~excavsim.loop.rig`: the loop's pieces around the world (planner, executor, scanner,
  keyframes) and the moves around every dig (park, scan, go home);
* :mod:`~excavsim.loop.episode`: :class:`Episode` (stepped) and :func:`run_episode` (to the end),
  the dig-scan-plan loop (§7.2), its stopping
  rules and metrics; :mod:`~excavsim.loop.digs`: where each cycle's dig comes from (the planner
  and its fallback, random feasible digs, scripted digs); :mod:`~excavsim.loop.demo`: the demo;
* :mod:`~excavsim.loop.scenario`: episode specifications;
* :mod:`~excavsim.loop.samples`, :mod:`~excavsim.loop.online`: force samples from digs, learning while
  digging; :mod:`~excavsim.loop.warmup`: the numba kernels compiled once.

Tasks (:mod:`excavsim.tasks`), applications (:mod:`excavsim.apps`) and studies (:mod:`excavsim.studies`:
campaigns, the regression suite, ``excavsim learn`` ...) stand on it. The loop never imports the
recorder: callers hand it in as an episode observer.
"""
