"""Truck loading by the mass-excavation script, self-tuned online (Rowe 1997 §4.3, §5, §6.2).

:mod:`~excavsim.tasks.dump_trial.trial` runs one trial; :mod:`~excavsim.tasks.dump_trial.tuning` the tuning over
trials (the tuner is the truck task's dig source); :mod:`~excavsim.tasks.dump_trial.episode` is the task of
an episode specification (the catalog's entry);
:mod:`~excavsim.tasks.dump_trial.campaign` compares tuned and untuned runs over seeds and soils.
"""
