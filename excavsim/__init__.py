"""excavsim: an open MuJoCo testbed for robotic trenching.

A simulated T3 hydraulic arm with an excavator bucket digs trenches in a heightfield soil box in a
closed scan-plan-dig loop (Singh 1995). See README.md and docs/architecture.md.

Subpackages follow the architecture: ``world`` is the truth (MuJoCo + soil), ``robot`` the arm's
kinematics and statics, ``sensing``/``planning``/``learning``/``execution`` the robot's mind,
``loop`` wires them, ``record`` observes; ``handoff`` holds the values passed between them and
``mechanics`` the soil mechanics the world and the mind share.
"""

import os

# Headless always: dm_control reads MUJOCO_GL when first imported and would otherwise try a window.
os.environ.setdefault("MUJOCO_GL", "disable")

from excavsim.errors import ConfigError, ExcavsimError, ModelError  # noqa: E402

__version__ = "0.1.0"
__all__ = ["ConfigError", "ExcavsimError", "ModelError", "__version__"]
