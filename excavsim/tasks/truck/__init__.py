"""Truck loading by the mass-excavation script, self-tuned online (Rowe 1997 §4.3, §5, §6.2).

:mod:`~excavsim.tasks.truck.trial` runs one trial and the tuning over trials;
:mod:`~excavsim.tasks.truck.campaign` compares tuned and untuned runs over seeds and soils.
"""
