"""Making a demonstration by teleoperation from a terminal (``excavsim playback --teleop``).

:func:`teleoperate` drives the T3 in MuJoCo from a key sequence (the key map of
:mod:`excavsim.execution.teleop`) and returns the measured tip poses and F/T forces as a
:class:`~excavsim.execution.demonstration.Demonstration` in the schema'd format; it takes any iterable of
keys, so a test gives it a string. :func:`tty_keys` is the thin terminal layer: single key presses from
a terminal in cbreak mode, refused with a clear error when standard input is not a terminal.

The arm starts 10 cm above the entry of the chapter-6 demonstration dig (:data:`~excavsim.handoff.dig.DEMO_ACTION`)
in the demonstration soil under DiMaio's model, the same world :func:`~excavsim.apps.playback.play.run_playback`
plays back in.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

import numpy as np

from excavsim.config import get_soil
from excavsim.errors import GoalError, UsageError
from excavsim.execution.demonstration import Demonstration, plane_state
from excavsim.execution.teleop import FINISH, HELP, TeleopOptions, apply_key, keys_of
from excavsim.handoff.episode import EpisodeObserver
from excavsim.rig.measures import episode_result, trench_footprint
from excavsim.apps.playback.play import DEMO_SOIL, demo_plan, make_world
from excavsim.rig.core import go_home, go_to, make_rig

START_HEIGHT_M = 0.10  # above the demonstration dig's entry


def teleoperate(keys: Iterable[str], *, seed: int = 0, soil: str = DEMO_SOIL,
                options: TeleopOptions = TeleopOptions(),
                on_key: Callable[[str, np.ndarray, np.ndarray], None] | None = None,
                observer: EpisodeObserver | None = None) -> Demonstration:
    """Drive the tip by ``keys`` and record the demonstration.

    Every key moves the commanded tip pose by one step (:func:`~excavsim.execution.teleop.apply_key`);
    the servo target is ramped to it over ``options.ticks_per_key`` control steps, and every control
    step's measured tip pose and plane F/T force is a sample. A pose out of reach is refused (the
    command stays where it was). Whitespace is skipped; :data:`~excavsim.execution.teleop.FINISH` ends.

    Args:
        keys: one-character strings (a str works).
        on_key: called after each key with the key, the measured tip pose (3,) and force (2,) [N].
        observer: sees the session as an episode of no dig (``started``, ``stepped`` after every control
            step, ``finished``): a :class:`~excavsim.record.trench.TrenchRecorder` handed in by the command
            records it or streams it live, so that the force is seen on the F/T plot while driving.

    Raises:
        ExcavsimError: an unknown key, or fewer than two samples (no key pressed).
    """
    if isinstance(keys, str):  # a whole sequence given: refuse a bad key before the world is built
        for key in keys_of(keys.split(FINISH)[0]):
            apply_key(np.zeros(3), key, options)
    sim = make_world(get_soil(soil), seed)
    rig = make_rig(sim, seed=seed)
    go_home(sim, rig)
    plan = demo_plan(sim, rig)
    waist = plan.waist
    pose = plan.poses[0] + np.array([0.0, START_HEIGHT_M, 0.0])
    q_start, ok = rig.arm.inverse(pose)
    if not ok:
        raise GoalError("teleop: the start pose above the demonstration dig is out of reach")
    obs_hooks = observer or EpisodeObserver()
    mask, z_goal = trench_footprint(sim, rig.goal, rig.width)
    h0, v0, wall0 = sim.soil.grid.heights.copy(), sim.soil.initial_volume, time.perf_counter()
    obs_hooks.started(sim, rig, mask, z_goal)
    sim.step_hooks.append(obs_hooks.stepped)
    try:
        demo, n_keys = _drive(keys, sim, rig, pose, q_start, waist, options, on_key, soil)
    except BaseException:
        obs_hooks.finished(None)
        raise
    obs_hooks.finished(episode_result(sim, [], "teleop", f"teleoperation ended after {n_keys} keys", mask=mask,
                                      z_goal=z_goal, h0=h0, v0=v0, wall_s=time.perf_counter() - wall0))
    return demo


def _drive(keys, sim, rig, pose, q_start, waist, options, on_key, soil: str) -> tuple[Demonstration, int]:
    """The key loop of :func:`teleoperate`: the demonstration and the number of keys taken."""
    target = rig.home.copy()
    target[0], target[1:4], target[4:] = waist, q_start, 0.0
    go_to(sim, target, rig.executor_cfg)
    obs = sim.observe()
    buf = np.zeros((4, 3))
    poses, forces = [], []
    n_keys = 0
    for key in keys:
        if key in (" ", "\n", "\r", "\t"):
            continue
        new = apply_key(pose, key, options)
        if new is None:
            break
        q_new, ok = rig.arm.inverse(new)
        if not ok:
            new, q_new = pose, target[1:4].copy()
        q_from = target[1:4].copy()
        for j in range(1, options.ticks_per_key + 1):
            target[1:4] = q_from + (q_new - q_from) * j / options.ticks_per_key
            obs = sim.track(target)
            tip, _, f = plane_state(rig.arm, rig.executor.ft, obs, waist, buf)
            poses.append(tip)
            forces.append(f)
        pose = new
        n_keys += 1
        if on_key is not None:
            on_key(key, poses[-1], forces[-1])
        if len(poses) >= options.max_keys * options.ticks_per_key:
            break
    if len(poses) < 2:
        raise UsageError(f"teleop: no key moved the arm, so there is no demonstration ({HELP})")
    n = len(poses)
    return Demonstration(np.arange(n) * sim.control_dt, np.array(poses), np.array(forces), sim.control_dt, waist,
                         f"teleoperation, {n_keys} keys, {n} samples", soil), n_keys


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


def teleop_session(out: str | Path, *, keys: Iterable[str] | None = None, seed: int = 0, record: str | None = None,
                   live: str | None = None, say: Callable[[str], None] = print) -> Path:
    """``excavsim playback --teleop``: drive the tip by ``keys`` (default: the terminal's) from 10 cm
    above the demonstration dig, saying each key's pose and force, and write the demonstration to
    ``out/teleop_demonstration.json``; returns that path.

    Args:
        record: a Rerun file to record the session to.
        live: stream the session to a Rerun viewer: "" spawns one, else its address.
    """
    import math

    observer = None
    if record or live is not None:
        from excavsim.record import TrenchRecorder
        from excavsim.record.live import viewer_url

        url = viewer_url(live or None) if live is not None else None
        if url:
            say(f"streaming the session live to {url}")
        observer = TrenchRecorder(record, live=url)
    keys = keys if keys is not None else tty_keys()
    say(f"excavsim playback --teleop: drive the bucket tip from 10 cm above the demonstration dig; {HELP}")
    demo = teleoperate(keys, seed=seed, observer=observer, on_key=lambda k, p, f: say(
        f"{k}: tip x {p[0]:.2f} m z {p[1]:.2f} m pitch {math.degrees(p[2]):.0f} deg | F radial {f[0]:7.0f} N "
        f"vertical {f[1]:7.0f} N"))
    if record:
        say(f"recorded to {record}; replay it with: excavsim replay {record}")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    path = demo.save(out / "teleop_demonstration.json")
    say(f"wrote {path} ({len(demo.times)} samples, {demo.times[-1]:.2f} s); play it back with: "
        f"excavsim playback --demo {path}")
    return path
