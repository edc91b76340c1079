"""What a machine brings to DiMaio's playback (DiMaio 1998 ch. 3, 6), and what every machine shares.

The one driver (:mod:`excavsim.apps.playback.driver`, with :mod:`excavsim.apps.playback.teleop`) records a
demonstration, plays it back with each impedance controller in fresh worlds of three soils and reports the
errors; it asks the machine's :class:`MachineAdapter` for what differs between machines:

* **the servos and the force**: joint servos and a wrist F/T sensor (the T3,
  :class:`~excavsim.apps.playback.servo_arm.ServoArm`), or cylinders whose forces give the soil's force on the
  bucket (the excavators, :class:`~excavsim.apps.playback.cylinder_arm.CylinderArm`). Both worlds are built by
  :func:`excavsim.world.machines.make_world` with the soil under DiMaio's model (:func:`dimaio_scene`);
* **its impedance** (:class:`Impedance`: Table 6.5's on the T3, Table 4.1's on an excavator);
* **its demonstration**: where it comes from (the executor's dig, a scripted cut) and how the machine goes to
  its start, and how a key moves it in teleoperation;
* **its words**: the table and the messages each kind has printed since it was written (kept as they were).

Which adapter a machine gets follows from its data (:func:`excavsim.apps.playback.machines.adapter_for`): a
machine with cylinders (:attr:`~excavsim.robot.machine.Machine.hydraulics`) gets a CylinderArm, one with joint
servos a ServoArm.

Shared by every machine: the soils (the demonstration's, :data:`DEMO_SOIL`, and its DiMaio terms scaled by
Table 6.4's kind of change, :func:`soils`; assumed factors :data:`STIFFER` and :data:`SOFTER`), §3.3.1's
weighting :data:`W` of the printed E, the 10 cm free descent before a recorded demonstration
(:data:`APPROACH_M`), and the playback itself (:class:`~excavsim.execution.playback.ImpedancePlayback`).
"""

from __future__ import annotations

import abc
import dataclasses
from collections.abc import Callable
from pathlib import Path

import numpy as np

from excavsim.apps.playback import DEFAULT_MACHINE
from excavsim.config import SceneConfig, SoilParams, get_soil, load_scene_config
from excavsim.errors import ConfigError, ExcavsimError, UsageError
from excavsim.execution.demonstration import Demonstration
from excavsim.execution.teleop import (FINISH, HELP, KEYS, SWING_HELP, SWING_KEYS, TeleopOptions, apply_key,
                                       apply_swing_key)
from excavsim.robot.kinematics import PlanarArm
from excavsim.robot.machine import Machine
from excavsim.world.machines import make_world

DEMO_SOIL = "testbed_sand"
# Table 6.4's kind of change (assumed factors): the playback soil is harder (softer) in every term
SCALED = ("viscous_tangential_n_s_m2", "viscous_normal_n_s_m2", "viscous_angular_n_s", "stiffness_n_m",
          "angular_stiffness_nm_rad", "shear_strength_pa", "accumulation_n_m3")
STIFFER, SOFTER = 3.0, 0.3
W = 1.0e6  # §3.3.1: 1 mm of position error weighs as 1 N of force error (for the printed E)
APPROACH_M, APPROACH_S = 0.10, 1.0  # the free descent prepended to a recorded demonstration: height [m], time [s]
TELEOP_HEIGHT_M = 0.10  # teleoperation starts this far above the demonstration's entry [m]
# the errors' file columns and their formats (the table of run_playback: errors, soil in the bucket)
CSV_FORMATS = {"pos_rms_m": ".4f", "pos_max_m": ".4f", "force_rms_n": ".1f", "force_max_err_n": ".1f",
               "force_peak_n": ".1f", "demo_force_peak_n": ".1f", "weighted_error": ".0f", "bucket_m3": ".5f"}


def scaled_soil(name: str, factor: float) -> SoilParams:
    """Soil ``name`` with its DiMaio stiffness/viscous/shear/accumulation terms times ``factor``."""
    soil = get_soil(name)
    dm = soil.dimaio
    return soil.model_copy(update={"dimaio": dm.model_copy(update={k: getattr(dm, k) * factor for k in SCALED})})


def soils(name: str = DEMO_SOIL) -> dict[str, SoilParams]:
    """The chapter-6 soils by label: the demonstration's, and its DiMaio terms x3 and x0.3."""
    return {"same": get_soil(name), f"stiffer x{STIFFER:g}": scaled_soil(name, STIFFER),
            f"softer x{SOFTER:g}": scaled_soil(name, SOFTER)}


def dimaio_scene() -> SceneConfig:
    """The scene of ``configs/scene.yaml`` with DiMaio's soil model as the world's truth (the chapter's worlds)."""
    scene = load_scene_config()
    return scene.model_copy(update={"truth": scene.truth.model_copy(update={"model": "dimaio"})})


@dataclasses.dataclass(frozen=True)
class Impedance:
    """A machine's impedance for the playback (eq. 3.15's Mm, Bm, Km) and its controllers' names.

    Attributes:
        source: where the numbers come from.
        mass_kg: the machine mass Mm [kg] (a virtual admittance mass on a position-servoed machine).
        k_high_n_m, k_low_n_m: the stiffness of position control and of the low impedance, and the variable
            impedance's bounds [N/m].
        damping_n_s_m: one damping Bm for every stiffness [N s/m]; None: by the damping factor 1,
            ``B = 2 sqrt(K M)``.
        g_n_s_m: eq. 3.37's velocity weighting G of the variable impedance [N s/m].
        position, low: the names of the fixed high and low impedance.
        moderate: fixed impedances between the two, (name, K [N/m]).
        g_sweep: the velocity-weighting sweep (Figs. 6.46-6.48), (name of the G, G [N s/m]); empty: none.
    """

    source: str
    mass_kg: float
    k_high_n_m: float
    k_low_n_m: float
    damping_n_s_m: float | None
    g_n_s_m: float
    position: str
    low: str
    moderate: tuple[tuple[str, float], ...] = ()
    g_sweep: tuple[tuple[str, float], ...] = ()

    @property
    def variable(self) -> str:
        """The variable impedance's name."""
        return f"variable (G={self.g_n_s_m:g})"

    @property
    def fixed(self) -> tuple[tuple[str, float], ...]:
        """The fixed impedances, (name, K [N/m]), from position control down to the low impedance."""
        return ((self.position, self.k_high_n_m), *self.moderate, (self.low, self.k_low_n_m))

    def sweep_name(self, g: float) -> str:
        """The name of the variable impedance with velocity weighting ``g`` of :attr:`g_sweep`."""
        key = next(k for k, v in self.g_sweep if v == g)
        return f"variable ({key}={g:g})"


class PlaybackRig(abc.ABC):
    """One world of a machine, as the playback needs it: the servos it commands, the robot's model of itself
    (:attr:`arm`), the force it reads (:attr:`force`, a :class:`~excavsim.sensing.ft.ForceSensor` or what
    offers its ``reading_into``) and the world itself (privileged, for the soil in the bucket).

    Subclasses set the attributes and :meth:`go_to_start`; the teleoperation hooks
    (:meth:`teleop_begin`, :meth:`teleop_target`, :meth:`teleop_step`, :meth:`teleop_end`) are what a key
    sequence needs (:func:`excavsim.apps.playback.teleop.teleoperate`).
    """

    world: object
    servos: object
    arm: PlanarArm
    force: object
    control_dt: float

    @abc.abstractmethod
    def go_to_start(self, pose: np.ndarray, swing: float) -> None:
        """Bring the tip to ``pose`` (x, z [m], pitch [rad]) in the arm plane at ``swing`` [rad].

        Raises:
            GoalError: the pose is out of the machine's reach.
        """
        raise NotImplementedError

    def bucket_m3(self) -> float:
        """The soil in the bucket now [m^3] (privileged truth, for the table)."""
        return float(self.world.truth.volumes.bucket)

    @abc.abstractmethod
    def teleop_begin(self, observer) -> tuple[np.ndarray, float, np.ndarray]:
        """Start a teleoperation session seen by ``observer`` (or None; its ``started`` is called here and its
        ``stepped`` after every control step): move to 10 cm above the demonstration's entry; the commanded tip
        pose (3,), swing [rad] and servo target there."""
        raise NotImplementedError

    @abc.abstractmethod
    def teleop_target(self, pose: np.ndarray, swing: float) -> np.ndarray | None:
        """The servo target of tip ``pose`` at ``swing``; None when it is out of reach."""
        raise NotImplementedError

    @abc.abstractmethod
    def teleop_step(self, target: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        """One control step towards ``target``: the measured tip pose (3,), the plane force (2,) [N] and the
        arm plane's swing [rad] of the sample."""
        raise NotImplementedError

    @abc.abstractmethod
    def teleop_end(self, n_keys: int | None) -> None:
        """The session ended after ``n_keys`` keys (None: it raised): the observer, if started, is told."""
        raise NotImplementedError


class MachineAdapter(abc.ABC):
    """A machine's side of the playback (see the module docstring); one subclass per kind of machine.

    Args:
        machine: the machine of :data:`excavsim.robot.machine.MACHINES`.

    Class attributes a kind sets: :attr:`impedance`; :attr:`table_header` and :attr:`row_format` (its errors
    table: a format string over the soil, the controller, the position errors in cm and the errors' keys);
    :attr:`csv_columns` (the errors file's columns);
    :attr:`chapter_report` (the closing note, the figures and Figs. 3.7-3.10's analysis, as on the T3);
    :attr:`swing_keys` (whether z/c swing the arm's plane in teleoperation); :attr:`holds_last_command` (whether
    a key's ramp starts from the last commanded servo target or from the last key's target: they differ by
    rounding only, and each kind keeps the demonstrations it made); and the words of its messages.
    """

    impedance: Impedance
    table_header: str
    row_format: str
    csv_columns: tuple[str, ...] = ("pos_rms_m", "pos_max_m", "force_rms_n", "force_max_err_n", "force_peak_n",
                                    "weighted_error")
    chapter_report = False
    swing_keys = False
    holds_last_command = False
    from_recordings = False  # --from-rrd: demonstrations read from a recorded dig's joints and F/T
    experiment = ""  # what the experiment does, after "excavsim playback: "
    teleop_intro = ""  # what teleoperation does, after "excavsim playback --teleop: "
    teleop_source = "teleoperation"  # a teleoperated demonstration's source, before ", N keys, M samples"
    radial = "x"  # the tip's radial coordinate's name in the per-key line
    recorded_words = "recorded to"  # "<these> FILE.rrd; replay it with: ..."

    def __init__(self, machine: Machine):
        self.machine = machine

    @property
    def name(self) -> str:
        return self.machine.name

    @property
    def title(self) -> str:
        """The machine's name in text (``TB035``)."""
        return self.machine.name.upper()

    @property
    def flag(self) -> str:
        """The command's ``--machine`` option for this machine ("" for the default one)."""
        return "" if self.name == DEFAULT_MACHINE else f" --machine {self.name}"

    @property
    def keys_help(self) -> str:
        return f"{HELP}; {SWING_HELP}" if self.swing_keys else HELP

    @abc.abstractmethod
    def rig(self, soil: SoilParams, seed: int = 0) -> PlaybackRig:
        """A fresh world of the machine in ``soil`` (under DiMaio's model) with ``seed``."""
        raise NotImplementedError

    @abc.abstractmethod
    def record_demonstration(self, seed: int = 0, soil: str = DEMO_SOIL) -> Demonstration:
        """The machine's own demonstration in ``soil`` (without the free descent)."""
        raise NotImplementedError

    def control_dt(self) -> float:
        """The machine's control period [s] (the period a demonstration must be sampled at)."""
        return float(make_world(self.name, scene=dimaio_scene()).control_dt)

    def check_rate(self, demo: Demonstration) -> None:
        """Refuse a demonstration sampled at another period than the machine's control period.

        Raises:
            ConfigError: naming both periods.
        """
        dt = self.control_dt()
        if abs(demo.dt - dt) > 1e-9:
            raise ConfigError(f"playback{self.flag}: the demonstration's dt {demo.dt} s is not the {self.title}'s "
                              f"control period {dt:g} s; record one on the {self.title}")

    def check_key(self, key: str, options: TeleopOptions) -> None:
        """Refuse a key that does not drive this machine.

        Raises:
            UsageError: naming the allowed keys.
        """
        if self.swing_keys and apply_swing_key(0.0, key, options) is not None:
            return
        try:
            apply_key(np.zeros(3), key, options)
        except ExcavsimError:
            swing = "".join(SWING_KEYS) if self.swing_keys else ""
            raise UsageError(f"teleop{self.flag}: unknown key {key!r}; allowed: {''.join(KEYS)}{swing} and "
                             f"{FINISH!r} ({self.keys_help})") from None

    @abc.abstractmethod
    def demonstration_note(self, raw: Demonstration, played: Demonstration) -> str:
        """The line saying what was recorded (``raw``) and will be played (``played``, with the descent)."""
        raise NotImplementedError

    def given_note(self, demo: Demonstration) -> str | None:
        """The line saying which demonstration was given, or None."""
        return None

    def table_row(self, soil: str, controller: str, e: dict) -> str:
        """One row of the errors table under :attr:`table_header`: ``e`` is
        :meth:`~excavsim.execution.playback.PlaybackRun.errors` with ``bucket_m3`` and ``outcome``."""
        row = self.row_format.format(soil=soil, controller=controller, pos_rms_cm=100 * e["pos_rms_m"],
                                     pos_max_cm=100 * e["pos_max_m"], **e)
        return row if e["outcome"] == "completed" else f"{row} | {e['outcome']}"  # a playback that failed

    def save_demonstration(self, demo: Demonstration, out: str | Path, name: str, say: Callable[[str], None],
                           what: str = "") -> Path:
        """Write ``demo`` to ``out/name`` and say where (``what`` after the path) and how to play it back."""
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        path = demo.save(out / name)
        say(f"wrote {path}{what} ({len(demo.times)} samples, {demo.times[-1]:.2f} s); play it back with: "
            f"excavsim playback{self.flag} --demo {path}")
        return path

    def check_from_recordings(self) -> None:
        """Refuse ``--from-rrd`` (a demonstration read from a recorded dig's joints and wrist F/T) on a machine
        that reads its force otherwise.

        Raises:
            UsageError: naming what to give instead.
        """
        if not self.from_recordings:
            raise UsageError(f"playback{self.flag}: --from-rrd reads a recorded dig's wrist F/T, which the "
                             f"{self.title} does not have (its force is read from its cylinders); give --demo "
                             "FILE.json or --teleop")

    def demonstration_from_signals(self, joint_times, joints, ft_times, ft_tip, path_world, *, source: str,
                                   soil: str = "") -> Demonstration:
        """A demonstration from a recorded dig's joints and F/T readings (``--from-rrd``), where
        :attr:`from_recordings`."""
        raise NotImplementedError

    def recorder(self, record: str | None, live: str | None, seed: int, say: Callable[[str], None]):
        """The observer that records a teleoperation session to ``record`` and streams it to the viewer at
        ``live`` ("" spawns one), or None for neither.

        Raises:
            ExcavsimError: nothing listens at ``live``, or no display to spawn a viewer on.
        """
        if not record and live is None:
            return None
        from excavsim.record.live import viewer_url

        url = viewer_url(live or None) if live is not None else None
        if url:
            say(f"streaming the session live to {url}")
        return self.session_recorder(record, url, seed)

    @abc.abstractmethod
    def session_recorder(self, record: str | None, url: str | None, seed: int):
        """The machine's recorder of a session to ``record`` and the viewer at gRPC ``url`` (either may be None)."""
