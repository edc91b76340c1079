"""Teleoperation from a terminal: keys move the bucket tip in the arm plane (DiMaio 1998 §6:
"manipulation of the ... joystick results in velocity commands which drive the bucket endpoint").

A key press moves the commanded tip pose (x radial, z up, pitch) by one step; the driver
(:func:`excavsim.apps.playback.teleop.teleoperate`) ramps the servo target to it over ``ticks_per_key`` control
steps and records the measured tip pose and F/T force at every step, which makes the
:class:`~excavsim.execution.demonstration.Demonstration`. The terminal is not the thesis' MagLev joystick
with force feedback: the force is only printed (and seen on the F/T plot when a recording is watched).

This module is the key map only (no world, no terminal), so that a key sequence is testable.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from excavsim.errors import ConfigError

# key -> (dx [steps], dz [steps], dpitch [steps]); "." waits one key period; FINISH ends the demonstration
KEYS = {"a": (-1, 0, 0), "d": (1, 0, 0), "w": (0, 1, 0), "s": (0, -1, 0), "q": (0, 0, 1), "e": (0, 0, -1),
        ".": (0, 0, 0)}
FINISH = "x"
# an excavator's swing (DiMaio 1998 §4.2: the endpoint in cylindrical coordinates, the cabin angle theta_1 first):
# key -> swing steps, counter-clockwise seen from above positive (the T3's waist is not driven by keys)
SWING_KEYS = {"z": 1, "c": -1}
SWING_HELP = "z/c swing the cab left/right"
HELP = ("keys: a/d tip toward/away from the base, w/s up/down, q/e bucket pitch up/down, '.' wait, "
        f"{FINISH!r} finish and write the demonstration")


@dataclasses.dataclass(frozen=True)
class TeleopOptions:
    """Step sizes of one key press.

    Attributes:
        step_m: tip displacement per key [m].
        pitch_step_rad: bucket pitch change per key [rad].
        ticks_per_key: control steps over which one key's move is ramped (0.01 s each at 100 Hz).
        max_keys: a demonstration ends after this many keys even without ``FINISH``.
        swing_step_rad: an excavator's swing per :data:`SWING_KEYS` press [rad].
    """

    step_m: float = 0.02
    pitch_step_rad: float = math.radians(3.0)
    ticks_per_key: int = 10
    max_keys: int = 5000
    swing_step_rad: float = math.radians(3.0)

    def __post_init__(self):
        if not (self.step_m > 0 and self.pitch_step_rad >= 0 and self.ticks_per_key >= 1 and self.max_keys >= 1
                and self.swing_step_rad >= 0):
            raise ConfigError(f"teleop options: step_m > 0, pitch_step_rad >= 0, ticks_per_key >= 1 and "
                              f"max_keys >= 1, swing_step_rad >= 0 required, got {self}")


def apply_key(pose: np.ndarray, key: str, options: TeleopOptions = TeleopOptions()) -> np.ndarray | None:
    """The commanded tip pose (3,) x, z [m], pitch [rad] after ``key``; None for :data:`FINISH`.

    Raises:
        ExcavsimError: a key that is not in :data:`KEYS` (naming the allowed keys).
    """
    if key == FINISH:
        return None
    if key not in KEYS:
        raise ConfigError(f"teleop: unknown key {key!r}; allowed: {''.join(KEYS)} and {FINISH!r} ({HELP})")
    step = np.array([options.step_m, options.step_m, options.pitch_step_rad])
    return np.asarray(pose, dtype=float) + step * np.array(KEYS[key])


def keys_of(text) -> list[str]:
    """The keys of a key sequence (a string or an iterable of characters), whitespace skipped."""
    return [k for k in text if k not in (" ", "\n", "\r", "\t")]


def apply_swing_key(swing: float, key: str, options: TeleopOptions = TeleopOptions()) -> float | None:
    """The commanded swing angle [rad] after ``key`` if it is one of :data:`SWING_KEYS`, else None."""
    if key not in SWING_KEYS:
        return None
    return float(swing) + SWING_KEYS[key] * options.swing_step_rad
