"""Truck loading to full by the 25 t excavator, pass after pass, self-tuned online (Rowe 1997 §4, §6).

:mod:`~excavsim.tasks.truck_loading.task` is the platform's task ``truck_loading`` (its class, the campaign
row, the per-pass rows and the printed table); :mod:`~excavsim.tasks.truck_loading.figure` draws the
Fig. 12-style learning curve over the passes. What is truck loading's alone is split by side, and
import-linter contracts keep the truth/belief rule between them: :mod:`~excavsim.tasks.truck_loading.mind`
(AutoDig, where to dig and dump) and :mod:`~excavsim.tasks.truck_loading.world` (the truck).
"""
