"""Truck loading, the truth: :mod:`~excavsim.tasks.truck_loading.world.truck`, the dump truck parked beside
the 25 t excavator's pit (its collision body, its bed's fill and volume account, its scanner) and the
excavator's world with it (:class:`~excavsim.tasks.truck_loading.world.truck.TruckWorld`).

The excavators' world itself (:mod:`excavsim.world.hydraulics`) is shared: trenching on the excavators and
playback run it too. An import-linter contract keeps every task's ``world`` package off the robot's mind.
"""
