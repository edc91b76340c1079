"""Commands for the T3's hydraulic servos (``intvelocity`` actuators in models/t3/t3.xml).

Each servo's control is the rate of its position set-point; MuJoCo integrates it into the
activation (the set-point) and drives the joint with ``kp (setpoint - q) - kv qdot`` clipped at the
relief torque. This module turns joint *targets* into set-point rates: proportional to the
remaining set-point error and clipped at the flow limit, so a commanded move runs at the joint's
speed limit until it nears the target. A joint that stalls (torque at its limit) lags its set-point;
the executor detects that from the tracking error.
"""

from __future__ import annotations

import numpy as np


def setpoint_rates(target: np.ndarray, q: np.ndarray, *, gain_per_s: float,
                   rate_limit: np.ndarray) -> np.ndarray:
    """Set-point rates that drive the joints towards ``target``.

    Args:
        target: (..., n) joint targets [rad].
        q: (..., n) measured joint angles [rad].
        gain_per_s: proportional gain from joint error to set-point rate [1/s].
        rate_limit: (n,) flow-limited speed of each joint (the actuators' ctrlrange) [rad/s].

    Returns:
        (..., n) controls for ``data.ctrl`` [rad/s].
    """
    rate_limit = np.asarray(rate_limit, dtype=float)
    return np.clip(gain_per_s * (np.asarray(target) - np.asarray(q)), -rate_limit, rate_limit)
