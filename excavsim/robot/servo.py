"""Commands for the T3's hydraulic servos (``intvelocity`` actuators in models/t3/t3.xml).

Each servo's control is the rate of its position set-point; MuJoCo integrates it into the
activation (the set-point) and drives the joint with ``kp (setpoint - q) - kv qdot`` clipped at the
relief torque. This module turns joint *targets* into set-point rates: proportional to the
remaining set-point error and clipped at the flow limit, so a commanded move runs at the joint's
speed limit until it nears the target. A joint that stalls (torque at its limit) lags its set-point;
the executor detects that from the tracking error.

The world calls :func:`setpoint_rates` every control step with one (n,) vector each: that case runs
compiled (:func:`_rates_1d`, the same numbers as numpy's clip, bit for bit), anything else through
numpy (:func:`setpoint_rates_reference`).
"""

from __future__ import annotations

import numba
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
    if (type(target) is np.ndarray and type(q) is np.ndarray and type(rate_limit) is np.ndarray
            and target.dtype == q.dtype == rate_limit.dtype == np.float64 and target.ndim == 1
            and target.shape == q.shape == rate_limit.shape and type(gain_per_s) is float):
        out = np.empty(target.shape[0])
        _rates_1d(target, q, gain_per_s, rate_limit, out)
        return out
    return setpoint_rates_reference(target, q, gain_per_s=gain_per_s, rate_limit=rate_limit)


def setpoint_rates_reference(target: np.ndarray, q: np.ndarray, *, gain_per_s: float,
                             rate_limit: np.ndarray) -> np.ndarray:
    """:func:`setpoint_rates` with numpy broadcasting (any shapes; the reference for the compiled case)."""
    rate_limit = np.asarray(rate_limit, dtype=float)
    return np.clip(gain_per_s * (np.asarray(target) - np.asarray(q)), -rate_limit, rate_limit)


@numba.njit(cache=True)
def _rates_1d(target, q, gain, limit, out):
    """``clip(gain (target - q), -limit, limit)`` element by element into ``out`` (NaN stays NaN, as in numpy)."""
    for k in range(target.shape[0]):
        v = gain * (target[k] - q[k])
        lo, hi = -limit[k], limit[k]
        if v < lo:
            v = lo
        if v > hi:
            v = hi
        out[k] = v
