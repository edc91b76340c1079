"""Truck loading, the robot's mind: the 25 t excavator's dig and its choices, from scans and sensors only.

* :mod:`~excavsim.tasks.truck_loading.mind.autodig`: AutoDig, the dig of one bucket load ended by angles
  and cylinder pressures (Rowe 1997 §4.4);
* :mod:`~excavsim.tasks.truck_loading.mind.planner`: where to dig next in the pit and where to dump next
  in the truck, from the scanned maps (Rowe 1997 §6.1).

Rowe's script that carries the load to the truck is shared with the dump trial
(:mod:`excavsim.execution.rowe_script`). numpy only: an import-linter contract keeps every task's ``mind``
package off the world, MuJoCo, dm_control and Rerun.
"""
