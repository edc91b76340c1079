"""The platform: the one episode driver and what every episode needs.

* :mod:`~excavsim.loop.episode`: :class:`~excavsim.loop.episode.Episode` (reset and stepped one
  cycle, or one phase, at a time), the :class:`~excavsim.loop.episode.Task` protocol a task
  supplies, and :class:`~excavsim.loop.episode.MapWriter`; :mod:`~excavsim.loop.digs`: the dig
  source protocol (:class:`~excavsim.loop.digs.DigSource`, :class:`~excavsim.loop.digs.Choice`);
* :mod:`~excavsim.loop.catalog`: the tasks by name (trench, load, truck), imported by entry point;
* :mod:`~excavsim.loop.rig`: the T3's pieces around the world (planner, executor, scanner,
  keyframes) and the moves around every dig (park, scan, go home); :mod:`~excavsim.loop.measures`:
  the privileged measures of a trench on the true terrain;
* :mod:`~excavsim.loop.scenario`: episode specifications (``task:``, ``machine:``, soil, seed, overrides);
* :mod:`~excavsim.loop.samples`: force samples from the T3's digs; :mod:`~excavsim.loop.warmup`: the
  numba kernels compiled once.

Tasks (:mod:`excavsim.tasks`: trenching, loading, truck loading), applications (:mod:`excavsim.apps`) and
studies (:mod:`excavsim.studies`: campaigns, the regression suite, ``excavsim learn`` ...) stand on it.
The loop never imports a task (the catalog names them) nor the recorder: callers hand it in as an
episode observer.
"""
