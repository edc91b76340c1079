"""DiMaio's playback on the TB035 mini-excavator (DiMaio 1998 §4.2, Table 4.1; the experiment of ch. 6).

The chapter-6 experiment of :mod:`excavsim.apps.playback.play` runs on the T3; here it runs on the
machine the thesis modelled, ``models/tb035`` in :class:`~excavsim.world.hydraulics.ExcavatorWorld`
(its cylinders within relief pressure and pump flow, the world's soil under DiMaio's model).

**Which impedance, and why Cartesian.** DiMaio §4.2 shapes the bucket endpoint's dynamics in the arm's
vertical plane by *position-based* impedance control into eq. 4.38,
``Mm x'' = f0 + fe + (Bm s + Km)(x0 - x)`` with ``x = (r, z, alpha)``, the machine's measured values in
Table 4.1 (M 100 kg, B 5000 N s/m, K 1e4 - 1e5 N/m). So the impedance here is Cartesian at the bucket tip
(radial and vertical, as the T3's), realised the same way: :class:`~excavsim.execution.playback.ImpedancePlayback`
integrates it as an admittance (App. A.2, eq. A.76) into a commanded tip, the planar inverse kinematics of
the machine's chain (read from its MJCF by :func:`~excavsim.robot.extract.arm_from_model`) gives joint
targets, and the hydraulic drive moves the cylinders to them (the position loop the real machine's
impedance controller sat on). A joint-space impedance would need the cylinders' force control, which the
model's valve law (flow-controlled cylinders) does not have, and Table 4.1's numbers are Cartesian. The bucket
angle follows the demonstration (no rotational impedance), as on the T3.

Table 4.1 gives one damping for its stiffness range: the fixed and variable laws use B = 5000 N s/m
throughout (the T3's use Table 6.5's damping factor instead). Controllers: position (K = 1e5), low (K = 1e4)
and the variable impedance of eq. 3.37 between them with the :class:`~excavsim.execution.playback.DepthDual`
depth law, the T3's chapter controller with Table 4.1's bounds.

**The force.** What the playback reads as fe is :class:`~excavsim.sensing.pressure.CylinderForceEstimate`:
the soil's force on the bucket from the cylinder forces (the pressure transducers) by a static balance of the
arm; the bucket pin's F/T does not see the link's load path. :class:`ExcavatorServos` presents the world to
the playback as the T3's servos: joint encoders and cylinder forces (with the transducers' noise,
:data:`CYLINDER_FORCE_NOISE_N`, assumed) padded to the T3's six joints.

**The demonstration** (:func:`record_demonstration`) is scripted: the tip driven by IK along a cut in the
pit (entry, down to :data:`DEMO_DEPTH_M`, a drag towards the machine, a curl) in the demonstration soil, the
measured tip pose and estimated force sampled every control step; a 10 cm free descent is prepended as
on the T3. Teleoperation makes one too (:func:`excavsim.apps.playback.teleop.teleoperate_tb035`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np

from excavsim.config import SoilParams, get_soil, load_scene_config
from excavsim.errors import ConfigError, ExcavsimError, GoalError
from excavsim.execution.demonstration import Demonstration, plane_state
from excavsim.execution.playback import DepthDual, FixedImpedance, ImpedancePlayback, PlaybackRun, VariableImpedance
from excavsim.handoff.observation import Observation
from excavsim.robot.extract import arm_from_model
from excavsim.robot.kinematics import PlanarArm
from excavsim.sensing.pressure import CylinderForceEstimate
from excavsim.world.hydraulics import EXCAVATOR_JOINTS, ExcavatorWorld

MACHINE = "tb035"
MASS, DAMPING, K_LOW, K_HIGH = 100.0, 5000.0, 1.0e4, 1.0e5  # DiMaio 1998 Table 4.1 (the excavator's column)
G_VARIABLE = 2000.0  # eq. 3.37's velocity weighting: the T3's chapter value (see the dated note for the TB035's)
W = 1.0e6  # §3.3.1's weighting for the printed E, as the T3's
CYLINDER_FORCE_NOISE_N = 100.0  # each cylinder force reading's noise (1 sigma) [N] (assumed: ~0.3 bar on its bore)
# The scripted demonstration: a cut in the arm plane at swing 0 (pit from x = 1.2 to 5.2 m)
DEMO_ENTRY_X_M, DEMO_END_X_M = 3.6, 2.6  # where the cut starts and ends, from the swing axis [m]
DEMO_DEPTH_M = 0.2  # below the ground
DEMO_PITCH, DEMO_CURL_PITCH = 0.6, -0.4  # the blade's rake while cutting and once curled [rad]
DEMO_SPEED_M_S = 0.2  # along the cut
VARIABLE = f"variable (G={G_VARIABLE:g})"
POSITION, LOW = "position (K=1e5)", "low (K=1e4)"
MACHINES = ("t3", MACHINE)


class ExcavatorServos:
    """An :class:`~excavsim.world.hydraulics.ExcavatorWorld` as the playback's servos (the
    :class:`~excavsim.handoff.observation.Servos` protocol, the T3's six joints): ``q``/``qdot`` are
    swing, boom, stick, bucket and two zeros, ``actuator_force`` the swing torque and the three cylinder
    forces (each with the transducers' Gaussian noise) and two zeros; ``track`` takes the first four
    targets. No F/T reading: ``ft_force``/``ft_torque`` are zero (the force is read from the cylinders).

    Args:
        world: the machine and its soil.
        seed: the noise's seed.
        noise_n: the cylinder forces' noise (1 sigma) [N].
    """

    def __init__(self, world: ExcavatorWorld, seed: int = 0, noise_n: float = CYLINDER_FORCE_NOISE_N):
        self.world = world
        self.control_dt = world.control_dt
        self.rng = np.random.default_rng(seed)
        self.noise_n = float(noise_n)
        m = world.model
        lim = np.abs(m.actuator_forcerange[world.drive.act]).max(axis=1)
        self.torque_limit = np.r_[lim, 0.0, 0.0]
        self._dof = np.array([m.jnt_dofadr[m.joint(j).id] for j in EXCAVATOR_JOINTS])
        self.step_hooks: list[Callable[[ExcavatorWorld], None]] = []

    @property
    def time(self) -> float:
        return float(self.world.data.time)

    def observe(self) -> Observation:
        """The joint encoders and the cylinder forces now (the forces with the transducers' noise)."""
        w = self.world
        forces = w.cylinder_forces() + self.rng.normal(0.0, self.noise_n, 4) * np.array([0.0, 1.0, 1.0, 1.0])
        z = np.zeros(2)
        return Observation(self.time, np.r_[w.joint_angles(), z], np.r_[w.data.qvel[self._dof], z],
                           np.r_[forces, z], np.zeros(3), np.zeros(3))

    def track(self, target: np.ndarray) -> Observation:
        """One control step towards the joint targets ``target[:4]`` (swing, boom, stick, bucket) [rad], then
        each of :attr:`step_hooks` with the world (a recorder's ``stepped``). The
        drive follows a moving target ``v / gain`` behind (5 cm at 0.2 m/s): the demonstration and its
        playback both have that lag. A velocity feed-forward on the targets was tried (seed 0): unfiltered it
        differentiates the admittance's response to the force noise and made every playback worse; low-passed
        (0.1 s, 0.3 s) it cut the same soil's position error (5.4 -> 3.5-4.2 cm) but raised the stiffer soil's
        force error (6.8 -> 8.2-8.7 kN for position control, seed 0), so it is not used."""
        self.world.step(np.asarray(target, dtype=float)[:4])
        for hook in self.step_hooks:
            hook(self.world)
        return self.observe()


def dimaio_world(soil: SoilParams | str, seed: int = 0) -> ExcavatorWorld:
    """The TB035 in its pit with ``soil`` under DiMaio's soil model (the chapter-6 worlds' truth)."""
    scene = load_scene_config()
    scene = scene.model_copy(update={"truth": scene.truth.model_copy(update={"model": "dimaio"})})
    return ExcavatorWorld(MACHINE, get_soil(soil) if isinstance(soil, str) else soil, scene, seed=seed)


class TB035Rig:
    """The TB035's world, servos, planar chain and force estimate for one playback or demonstration."""

    def __init__(self, soil: SoilParams | str, seed: int = 0):
        self.world = dimaio_world(soil, seed)
        self.servos = ExcavatorServos(self.world, seed)
        self.arm: PlanarArm = arm_from_model(self.world.model, joints=EXCAVATOR_JOINTS)
        self.force = CylinderForceEstimate(self.world.spec, self.arm)

    def joints_of(self, pose: np.ndarray, swing: float = 0.0) -> np.ndarray:
        """(4,) joint targets of tip pose ``pose`` (x, z, pitch) at ``swing`` [rad].

        Raises:
            GoalError: the pose is out of the TB035's reach or joint limits.
        """
        q, ok = self.arm.inverse(np.asarray(pose, dtype=float))
        if not ok:
            raise GoalError(f"the tip pose {np.round(pose, 3).tolist()} (x, z [m], pitch [rad]) is out of the "
                            "TB035's reach or joint limits")
        return np.r_[swing, q]

    def move_to(self, q: np.ndarray, *, tol: float = 0.01, timeout_s: float = 8.0) -> None:
        """A joint move to ``q`` (4,) until every joint is within ``tol`` rad (or ``timeout_s``)."""
        for _ in range(int(timeout_s / self.world.control_dt)):
            if np.all(np.abs(self.servos.track(q).q[:4] - q) <= tol):
                break

    def sample(self, swing: float) -> tuple[np.ndarray, np.ndarray]:
        """The tip pose (3,) and the soil's force in the arm plane (2,) [N] as the mind senses them now."""
        tip, _, f = plane_state(self.arm, self.force, self.servos.observe(), swing, np.zeros((4, 3)))
        return tip, f


def demonstration_path(speed: float = DEMO_SPEED_M_S) -> list[np.ndarray]:
    """The scripted demonstration's waypoints (x, z, pitch): the entry on the surface, down to the depth,
    the drag towards the machine and the curl."""
    d = DEMO_DEPTH_M
    return [np.array(p) for p in ((DEMO_ENTRY_X_M, 0.0, DEMO_PITCH), (DEMO_ENTRY_X_M, -d, DEMO_PITCH),
                                  (DEMO_END_X_M, -d, DEMO_PITCH), (DEMO_END_X_M, -d + 0.1, DEMO_CURL_PITCH))]


def record_demonstration(seed: int = 0, soil: str = "testbed_sand", *, speed: float = DEMO_SPEED_M_S) -> Demonstration:
    """Drive the TB035's tip along :func:`demonstration_path` in ``soil`` (IK targets at the control rate) and
    take the measured tip pose and estimated soil force of every control step as the demonstration."""
    rig = TB035Rig(soil, seed)
    path = demonstration_path()
    rig.move_to(rig.joints_of(path[0] + np.array([0.0, 0.3, 0.0])))
    rig.move_to(rig.joints_of(path[0]))
    poses, forces = [], []
    dt = rig.world.control_dt
    for a, b in zip(path[:-1], path[1:]):
        n = max(1, int(math.ceil(max(np.linalg.norm(b[:2] - a[:2]) / speed, abs(b[2] - a[2]) / 1.0) / dt)))
        for k in range(1, n + 1):
            rig.servos.track(rig.joints_of(a + (b - a) * k / n))
            tip, f = rig.sample(0.0)
            poses.append(tip)
            forces.append(f)
    n = len(poses)
    return Demonstration(np.arange(n) * dt, np.array(poses), np.array(forces), dt, 0.0,
                         f"TB035 scripted cut {DEMO_ENTRY_X_M:g} -> {DEMO_END_X_M:g} m at {DEMO_DEPTH_M:g} m deep, "
                         f"{speed:g} m/s", soil)


def controllers(g: float = G_VARIABLE) -> list:
    """Table 4.1's fixed extremes and the variable impedance between them (eq. 3.37 with velocity weighting
    ``g`` [N s/m] and the depth law)."""
    name = VARIABLE if g == G_VARIABLE else f"variable (G={g:g})"
    return [FixedImpedance(POSITION, MASS, K_HIGH, damping=DAMPING), FixedImpedance(LOW, MASS, K_LOW, damping=DAMPING),
            VariableImpedance(name, MASS, K_LOW, K_HIGH, g, depth=DepthDual(w=W), damping=DAMPING)]


def play(demo: Demonstration, soil: SoilParams, label: str, law, seed: int = 0) -> tuple[PlaybackRun, float]:
    """One playback of ``demo`` on the TB035 in a fresh world of ``soil``; the run and the soil in the bucket
    at its end [m^3] (privileged truth, for the table)."""
    rig = TB035Rig(soil, seed)
    start = rig.joints_of(demo.pose[0], demo.waist)
    rig.move_to(np.r_[demo.waist, rig.joints_of(demo.pose[0] + np.array([0.0, 0.3, 0.0]))[1:]])
    rig.move_to(start)
    run = ImpedancePlayback(rig.servos, rig.arm, rig.force, law).run(demo, soil=label)
    return run, float(rig.world.soil.volumes().bucket)


def t3_play(demo: Demonstration, soil: SoilParams, label: str, law, seed: int = 0) -> tuple[PlaybackRun, float]:
    """The T3's playback (:func:`excavsim.apps.playback.play.play`) with the soil in its bucket at the end."""
    from excavsim.apps.playback.play import play_in_world

    run, sim = play_in_world(demo, soil, label, law, seed)
    return run, float(sim.truth.volumes.bucket)


def soils(name: str = "testbed_sand") -> dict[str, SoilParams]:
    """The chapter-6 soils: the demonstration's, and its DiMaio terms x3 and x0.3 (as on the T3)."""
    from excavsim.apps.playback.play import SOFTER, STIFFER, scaled_soil

    return {"same": get_soil(name), f"stiffer x{STIFFER:g}": scaled_soil(name, STIFFER),
            f"softer x{SOFTER:g}": scaled_soil(name, SOFTER)}


def run_tb035(out: Path | None = None, *, seed: int = 0, demo: Demonstration | None = None, g: float = G_VARIABLE,
              progress: Callable[[str], None] = print) -> dict:
    """The experiment on the TB035: record (or take) a demonstration, play it back in the three soils with
    the three controllers; returns ``{(soil, controller): errors + soil moved}`` and writes
    ``demonstration.json`` and ``errors.csv`` into ``out``."""
    if demo is None:
        demo = record_demonstration(seed).with_approach(0.10, 1.0)
        progress(f"TB035 demonstration: {len(demo.times)} samples ({demo.times[-1]:.2f} s) in {demo.soil}; "
                 f"{demo.source}; force peak {np.linalg.norm(demo.force, axis=1).max():.0f} N")
    elif abs(demo.dt - 0.02) > 1e-9:
        raise ConfigError(f"playback --machine tb035: the demonstration's dt {demo.dt} s is not the TB035's "
                            "control period 0.02 s (a T3 demonstration is at 0.01 s); record one on the TB035")
    table = {}
    progress(f"{'soil':12s} {'controller':20s} {'pos RMS/max [cm]':>17s} | {'force RMS/peak [N]':>19s} | "
             f"{'E':>10s} | {'bucket [m^3]':>12s}")
    for label, soil in soils().items():
        for law in controllers(g):
            run, moved = play(demo, soil, label, law, seed)
            e = table[label, law.name] = {**run.errors(W), "bucket_m3": moved, "outcome": run.outcome}
            progress(f"{label:12s} {law.name:20s} {100 * e['pos_rms_m']:7.2f} / {100 * e['pos_max_m']:6.2f}  | "
                     f"{e['force_rms_n']:8.0f} / {e['force_peak_n']:8.0f} | {e['weighted_error']:10.0f} | "
                     f"{moved:12.4f}" + ("" if run.outcome == "completed" else f" | {run.outcome}"))
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        demo.save(out / "demonstration.json")
        lines = ["soil,controller,pos_rms_m,pos_max_m,force_rms_n,force_peak_n,demo_force_peak_n,weighted_error,bucket_m3"]
        lines += [f"{s},{c},{e['pos_rms_m']:.4f},{e['pos_max_m']:.4f},{e['force_rms_n']:.1f},{e['force_peak_n']:.1f},"
                  f"{e['demo_force_peak_n']:.1f},{e['weighted_error']:.0f},{e['bucket_m3']:.5f}"
                  for (s, c), e in table.items()]
        (out / "errors.csv").write_text("\n".join(lines) + "\n")
        progress(f"wrote {out}/demonstration.json and errors.csv")
    return table


def teleoperate_tb035(keys, *, seed: int = 0, soil: str = "testbed_sand", options=None,
                      on_key: Callable[[str, np.ndarray, np.ndarray], None] | None = None,
                      observer=None) -> Demonstration:
    """Drive the TB035 by keys and record the demonstration (``excavsim playback --teleop --machine tb035``).

    The keys of :mod:`excavsim.execution.teleop` move the commanded tip in the arm plane (a/d radial, w/s up
    and down, q/e the bucket's pitch) and :data:`~excavsim.execution.teleop.SWING_KEYS` (z/c) the cab's swing:
    DiMaio §4.2's cylindrical endpoint coordinates (theta_1, r, z, alpha), so all four joints are driven. Each
    key's move is ramped over ``options.ticks_per_key`` control steps; every step's measured tip pose and
    estimated soil force is a sample. A pose out of reach is refused (the command stays). The session starts
    10 cm above the scripted demonstration's entry. The demonstration's arm plane is the median swing of the
    session (a playback replays the planar path at one swing angle).

    Args:
        observer: sees the session (``started(world)``, ``stepped(world)`` after every control step,
            ``finished(world)``), e.g. an :class:`~excavsim.record.excavator.ExcavatorRecorder`.

    Raises:
        ExcavsimError: an unknown key, or no key moved the machine.
    """
    from excavsim.errors import UsageError
    from excavsim.execution.teleop import FINISH, HELP, SWING_HELP, TeleopOptions, apply_key, apply_swing_key, keys_of

    options = options or TeleopOptions()
    allowed = f"{HELP}; {SWING_HELP}"

    def check(key: str) -> None:
        if apply_swing_key(0.0, key, options) is None:
            try:
                apply_key(np.zeros(3), key, options)
            except ExcavsimError:
                raise UsageError(f"teleop --machine tb035: unknown key {key!r} ({allowed})") from None

    if isinstance(keys, str):
        for key in keys_of(keys.split(FINISH)[0]):
            check(key)
    rig = TB035Rig(soil, seed)
    if observer is not None:
        observer.started(rig.world)
        rig.servos.step_hooks.append(observer.stepped)
    try:
        return _drive_tb035(keys, rig, options, check, on_key, soil)
    finally:
        if observer is not None:
            observer.finished(rig.world)


def _drive_tb035(keys, rig: TB035Rig, options, check, on_key, soil: str) -> Demonstration:
    """The key loop of :func:`teleoperate_tb035`."""
    from excavsim.errors import UsageError
    from excavsim.execution.teleop import FINISH, HELP, SWING_HELP, apply_key, apply_swing_key

    allowed = f"{HELP}; {SWING_HELP}"
    pose = demonstration_path()[0] + np.array([0.0, 0.10, 0.0])
    swing = 0.0
    target = rig.joints_of(pose, swing)
    rig.move_to(target, tol=0.002)
    poses, forces, swings = [], [], []
    n_keys = 0
    for key in keys:
        if key in (" ", "\n", "\r", "\t"):
            continue
        if key == FINISH:
            break
        check(key)
        new_swing = apply_swing_key(swing, key, options)
        new_pose = pose if new_swing is not None else apply_key(pose, key, options)
        new_swing = swing if new_swing is None else new_swing
        try:
            new_target = rig.joints_of(new_pose, new_swing)
        except GoalError:
            new_pose, new_swing, new_target = pose, swing, target
        start = target.copy()
        for j in range(1, options.ticks_per_key + 1):
            target = start + (new_target - start) * j / options.ticks_per_key
            q = rig.servos.track(target).q
            tip, f = rig.sample(q[0])
            poses.append(tip)
            forces.append(f)
            swings.append(q[0])
        pose, swing, target = new_pose, new_swing, new_target
        n_keys += 1
        if on_key is not None:
            on_key(key, poses[-1], forces[-1])
        if n_keys >= options.max_keys:
            break
    if len(poses) < 2:
        raise UsageError(f"teleop --machine tb035: no key moved the machine, so there is no demonstration ({allowed})")
    n = len(poses)
    dt = rig.world.control_dt
    return Demonstration(np.arange(n) * dt, np.array(poses), np.array(forces), dt, float(np.median(swings)),
                         f"TB035 teleoperation, {n_keys} keys, {n} samples", soil)


def command(out: str | Path, *, seed: int = 0, demo_path: str | None = None, teleop: bool = False, keys=None,
            record: str | None = None, say: Callable[[str], None] = print) -> Path | None:
    """``excavsim playback --machine tb035``: the experiment on the TB035 (:func:`run_tb035`), with the
    demonstration of ``demo_path`` when given; with ``teleop`` a teleoperated demonstration instead, written to
    ``out/teleop_demonstration.json`` (returned), the session recorded to ``record`` (an ``.rrd``) when given."""
    out = Path(out)
    if teleop:
        from excavsim.apps.playback.teleop import tty_keys
        from excavsim.execution.teleop import HELP, SWING_HELP

        say(f"excavsim playback --teleop --machine tb035: drive the TB035's bucket from 10 cm above the "
            f"demonstration cut; {HELP}; {SWING_HELP}")
        observer = None
        if record:
            from excavsim.record.excavator import ExcavatorRecorder

            observer = ExcavatorRecorder(record, seed=seed)
        demo = teleoperate_tb035(keys if keys is not None else tty_keys(), seed=seed, observer=observer,
                                 on_key=lambda k, p, f: say(
            f"{k}: tip r {p[0]:.2f} m z {p[1]:.2f} m pitch {math.degrees(p[2]):.0f} deg | F radial {f[0]:7.0f} N "
            f"vertical {f[1]:7.0f} N"))
        if record:
            say(f"recorded the session to {record}; replay it with: excavsim replay {record}")
        out.mkdir(parents=True, exist_ok=True)
        path = demo.save(out / "teleop_demonstration.json")
        say(f"wrote {path} ({len(demo.times)} samples, {demo.times[-1]:.2f} s); play it back with: "
            f"excavsim playback --machine tb035 --demo {path}")
        return path
    from excavsim.execution.demonstration import load_demonstration

    say("excavsim playback --machine tb035: demonstrate a cut on the TB035, replay it in the same, a stiffer and a "
        "softer soil with DiMaio 1998 Table 4.1's impedance (M 100 kg, B 5000 N s/m, K 1e4 / 1e5 N/m and variable)")
    run_tb035(out, seed=seed, demo=load_demonstration(demo_path) if demo_path else None, progress=say)
    return None
