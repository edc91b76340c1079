"""The world (truth): scene composition, MuJoCo physics, and (later) the soil model.

Nothing here imports the robot's mind (sensing, planning, learning, execution).
"""
