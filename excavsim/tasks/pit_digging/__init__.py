"""Digging a rectangular pit with the T3, lane by lane: the example of a task written as one folder.

:mod:`~excavsim.tasks.pit_digging.plugin` is what the platform knows of the task (registered by one line of
:mod:`excavsim.loop.catalog`); :mod:`~excavsim.tasks.pit_digging.goal` the pit and its lanes;
:mod:`~excavsim.tasks.pit_digging.task` the episode's task part, its result and rows;
:mod:`~excavsim.tasks.pit_digging.digs` its dig source; :mod:`~excavsim.tasks.pit_digging.recording` its Rerun
recorder; :mod:`~excavsim.tasks.pit_digging.env` its Gymnasium environment. The docs' "Write your own task"
page walks through them.
"""
