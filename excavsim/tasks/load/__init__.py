"""Loading from a pile: the 2-D simulation (:mod:`~excavsim.tasks.load.planar`, 000_a3ca905d8c6d92bf.txt §7.2.1) and the MuJoCo one (:mod:`~excavsim.tasks.load.in_mujoco`) with the front loader or the front shovel.

The mind-side pieces (the loading planner) stay in :mod:`excavsim.planning` so that the truth/belief
contracts cover them; this package wires them to the worlds and keeps the campaigns and tables.
"""
