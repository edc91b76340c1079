"""Making a demonstration by teleoperation from a terminal (``excavsim playback --teleop [--machine NAME]``).

:func:`teleoperate` drives any machine of the playback in MuJoCo from a key sequence (the key map of
:mod:`excavsim.execution.teleop`) and returns the measured tip poses and forces as a
:class:`~excavsim.execution.demonstration.Demonstration` in the schema'd format; it takes any iterable of
keys, so a test gives it a string. :func:`tty_keys` is the thin terminal layer: single key presses from
a terminal in cbreak mode, refused with a clear error when standard input is not a terminal.

The machine starts 10 cm above the entry of its demonstration (the T3: the chapter-6 dig of
:data:`~excavsim.handoff.dig.DEMO_ACTION`; an excavator: its scripted cut) in the demonstration soil under
DiMaio's model, the same world :func:`~excavsim.apps.playback.driver.run_playback` plays back in. Each key
moves the commanded tip in the arm plane (a/d radial, w/s up and down, q/e the bucket's pitch); on a machine
whose adapter says so (the excavators) z/c swing the arm's plane: DiMaio §4.2's cylindrical endpoint
coordinates (theta_1, r, z, alpha), so all four joints are driven. Each key's move is ramped over
``options.ticks_per_key`` control steps, and every step's measured tip pose and force is a sample; a pose out
of reach is refused (the command stays). The demonstration's arm plane is the session's median swing (a
playback replays the planar path at one swing angle).
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

import numpy as np

from excavsim.apps.playback import DEFAULT_MACHINE
from excavsim.apps.playback.adapter import DEMO_SOIL, MachineAdapter, PlaybackRig
from excavsim.apps.playback.machines import adapter_for
from excavsim.config import get_soil
from excavsim.errors import UsageError
from excavsim.execution.demonstration import Demonstration
from excavsim.execution.teleop import FINISH, HELP, TeleopOptions, apply_key, apply_swing_key, keys_of

WHITESPACE = (" ", "\n", "\r", "\t")


def teleoperate(keys: Iterable[str], *, machine: str = DEFAULT_MACHINE, seed: int = 0, soil: str = DEMO_SOIL,
                options: TeleopOptions | None = None,
                on_key: Callable[[str, np.ndarray, np.ndarray], None] | None = None,
                observer=None) -> Demonstration:
    """Drive ``machine``'s tip by ``keys`` and record the demonstration (see the module docstring).

    Whitespace is skipped; :data:`~excavsim.execution.teleop.FINISH` ends.

    Args:
        keys: one-character strings (a str works).
        on_key: called after each key with the key, the measured tip pose (3,) and force (2,) [N].
        observer: sees the session: on the T3 as an episode of no dig (``started``, ``stepped`` after every
            control step, ``finished``; a :class:`~excavsim.record.trench.TrenchRecorder` handed in by the
            command records it or streams it live, so that the force is seen on the F/T plot while driving), on
            an excavator as a run of the machine (an :class:`~excavsim.record.excavator.ExcavatorRecorder`).

    Raises:
        ExcavsimError: an unknown key, or fewer than two samples (no key moved the machine).
    """
    pm = adapter_for(machine)
    options = options or TeleopOptions()
    if isinstance(keys, str):  # a whole sequence given: refuse a bad key before the world is built
        for key in keys_of(keys.split(FINISH)[0]):
            pm.check_key(key, options)
    rig = pm.rig(get_soil(soil), seed)
    try:
        pose, swing, target = rig.teleop_begin(observer)
        demo, n_keys = _drive(keys, pm, rig, pose, swing, target, options, on_key, soil)
    except BaseException:
        rig.teleop_end(None)
        raise
    rig.teleop_end(n_keys)
    return demo


def _drive(keys, pm: MachineAdapter, rig: PlaybackRig, pose: np.ndarray, swing: float, target: np.ndarray,
           options: TeleopOptions, on_key, soil: str) -> tuple[Demonstration, int]:
    """The key loop of :func:`teleoperate`: the demonstration and the number of keys taken."""
    poses, forces, swings = [], [], []
    n_keys = 0
    for key in keys:
        if key in WHITESPACE:
            continue
        if key == FINISH:
            break
        pm.check_key(key, options)
        new_swing = apply_swing_key(swing, key, options) if pm.swing_keys else None
        new_pose = pose if new_swing is not None else apply_key(pose, key, options)
        new_swing = swing if new_swing is None else new_swing
        new_target = rig.teleop_target(new_pose, new_swing)
        if new_target is None:  # out of reach: the command stays
            new_pose, new_swing, new_target = pose, swing, target
        start = target.copy()
        for j in range(1, options.ticks_per_key + 1):
            command = start + (new_target - start) * j / options.ticks_per_key
            tip, f, plane = rig.teleop_step(command)
            poses.append(tip)
            forces.append(f)
            swings.append(plane)
        pose, swing = new_pose, new_swing
        target = command if pm.holds_last_command else new_target
        n_keys += 1
        if on_key is not None:
            on_key(key, poses[-1], forces[-1])
        if n_keys >= options.max_keys:
            break
    if len(poses) < 2:
        raise UsageError(f"teleop{pm.flag}: no key moved the machine, so there is no demonstration ({pm.keys_help})")
    n = len(poses)
    dt = rig.control_dt
    return Demonstration(np.arange(n) * dt, np.array(poses), np.array(forces), dt, float(np.median(swings)),
                         f"{pm.teleop_source}, {n_keys} keys, {n} samples", soil), n_keys


def tty_keys(stream=None) -> Iterator[str]:
    """Single key presses from the terminal on ``stream`` (default standard input), until
    :data:`~excavsim.execution.teleop.FINISH`, end of input or Ctrl-C; the terminal is restored after.

    Raises:
        ExcavsimError: ``stream`` is not a terminal.
    """
    stream = sys.stdin if stream is None else stream
    if not (hasattr(stream, "isatty") and stream.isatty()):
        raise UsageError("playback --teleop: standard input is not a terminal, so keys cannot be read one by "
                         f"one; run it in a terminal, or give the keys with --keys SEQUENCE ({HELP})")
    import termios
    import tty

    fd = stream.fileno()
    saved = termios.tcgetattr(fd)
    try:
        tty.setcbreak(fd)
        while True:
            ch = stream.read(1)
            if not ch or ch == "\x03":
                return
            yield ch
            if ch == FINISH:
                return
    finally:
        termios.tcsetattr(fd, termios.TCSADRAIN, saved)


def teleop_session(out: str | Path, *, machine: str = DEFAULT_MACHINE, keys: Iterable[str] | None = None,
                   seed: int = 0, record: str | None = None, live: str | None = None,
                   say: Callable[[str], None] = print) -> Path:
    """``excavsim playback --teleop [--machine NAME]``: drive ``machine``'s bucket by ``keys`` (default: the
    terminal's) from 10 cm above its demonstration's entry, saying each key's pose and force, and write the
    demonstration to ``out/teleop_demonstration.json``; returns that path.

    Args:
        record: a Rerun file to record the session to.
        live: stream the session to a Rerun viewer: "" spawns one, else its address.
    """
    pm = adapter_for(machine)
    observer = pm.recorder(record, live, seed, say)
    keys = keys if keys is not None else tty_keys()
    say(f"excavsim playback --teleop{pm.flag}: {pm.teleop_intro}; {pm.keys_help}")
    demo = teleoperate(keys, machine=machine, seed=seed, observer=observer, on_key=lambda k, p, f: say(
        f"{k}: tip {pm.radial} {p[0]:.2f} m z {p[1]:.2f} m pitch {math.degrees(p[2]):.0f} deg | F radial {f[0]:7.0f} N "
        f"vertical {f[1]:7.0f} N"))
    if record:
        say(f"{pm.recorded_words} {record}; replay it with: excavsim replay {record}")
    return pm.save_demonstration(demo, out, "teleop_demonstration.json", say)
