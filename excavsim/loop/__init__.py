"""The platform: the one episode driver, the plug-in contract of a task, and the catalog of tasks.

* :mod:`~excavsim.loop.episode`: :class:`~excavsim.loop.episode.Episode` (reset and stepped one
  cycle, or one phase, at a time), the :class:`~excavsim.loop.episode.Task` protocol a task's episode
  supplies, and :class:`~excavsim.loop.episode.MapWriter`; :mod:`~excavsim.loop.digs`: the dig
  source protocol (:class:`~excavsim.loop.digs.DigSource`, :class:`~excavsim.loop.digs.Choice`);
* :mod:`~excavsim.loop.plugin`: :class:`~excavsim.loop.plugin.TaskPlugin`, everything the platform,
  the CLI, ``validate`` and the studies ask of a task; :mod:`~excavsim.loop.catalog`: the one list of
  tasks (one line each, or an entry point of the group ``excavsim.tasks``);
* :mod:`~excavsim.loop.scenario`: episode specifications (the common fields, the task's own handed to
  its plug-in), resolved, run and summarized by the task's plug-in;
* :mod:`~excavsim.loop.warmup`: every task's numba kernels compiled once.

Tasks (:mod:`excavsim.tasks`, one folder each), applications (:mod:`excavsim.apps`) and studies
(:mod:`excavsim.studies`) stand on it. The loop names no task and no machine, and imports neither a
task (the catalog names them by entry point) nor the recorder (a task's plug-in makes it).
"""
