"""Loading from a pile, the truth: the worlds the loading machines dig in.

* :mod:`~excavsim.tasks.pile_loading.world.scene`: the MuJoCo world, a front loader or a front shovel
  beside a pile lane, stepped with the world's soil model;
* :mod:`~excavsim.tasks.pile_loading.world.pile2d`: the 2-D world of §7.2.1, a pile's profile on flat
  ground that digs carve and settlement relaxes.

An import-linter contract keeps every task's ``world`` package off the robot's mind (sensing, planning,
learning, execution and the task's ``mind`` package).
"""
