"""The world (truth): the scene, MuJoCo physics, the soil and the simulated sensors that read the truth.

* :mod:`~excavsim.world.scene`: the scene composed from ``models/`` with PyMJCF and the configurations;
* :mod:`~excavsim.world.simulation`: :class:`Simulation`, MuJoCo and the soil stepped together at the
  control rate, the facade the rest of the package talks to; :mod:`~excavsim.world.facade`:
  :class:`~excavsim.world.facade.World`, the protocol it shares with the other tasks' worlds;
* :mod:`~excavsim.world.terrain`, :mod:`~excavsim.world.bucket`, :mod:`~excavsim.world.settle`,
  :mod:`~excavsim.world.soil`, :mod:`~excavsim.world.kernels`: the heightfield soil, the bucket's
  sampled geometry, settlement, and the bucket-soil model with its compiled kernels;
* :mod:`~excavsim.world.scanner`, :mod:`~excavsim.world.raycast`: the laser scanner, whose rays hit
  the true terrain (the robot receives only its range images).

Nothing here imports the robot's mind (sensing, planning, learning, execution); an import-linter
contract keeps it so.
"""
