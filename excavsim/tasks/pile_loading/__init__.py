"""Loading from a pile: the 2-D simulation and the MuJoCo one (Singh 1995 §7.2.1).

:mod:`~excavsim.tasks.pile_loading.planar` is the 2-D simulation, :mod:`~excavsim.tasks.pile_loading.task` the
MuJoCo episode with the front loader or the front shovel. What is loading's alone is split by side, and
import-linter contracts keep the truth/belief rule between them: :mod:`~excavsim.tasks.pile_loading.mind`
(the loading planner and the joint-space script) and :mod:`~excavsim.tasks.pile_loading.world` (the MuJoCo
loading world and the 2-D pile).
"""
