"""Demonstrations: a demonstrated dig as tip pose and tip force in the arm plane, its file format, and
where demonstrations come from (DiMaio 1998 §3.1, ch. 6).

A :class:`Demonstration` is a time series, uniform at the control period, of the bucket-tip pose
(x, z, pitch) and the environment's force on the bucket (radial, vertical) in the arm plane. It is
taken from an executor record (:func:`demonstration_from_record`), from sampled joints and F/T readings
such as a Rerun recording holds (:func:`demonstration_from_joints`), or made by teleoperation
(:mod:`excavsim.execution.teleop`, driven by :mod:`excavsim.apps.playback.teleop`). Files are JSON with a schema
(:data:`SCHEMA`) that :func:`load_demonstration` checks on load. Played back by
:mod:`excavsim.execution.playback`.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np

from excavsim.errors import DataFileError, UsageError, shorten
from excavsim.handoff.dig import ExecutionRecord
from excavsim.handoff.observation import Observation
from excavsim.robot.kinematics import PlanarArm
from excavsim.sensing.ft import ForceSensor

SCHEMA_VERSION = 1
# the demonstration file: every key required, arrays of the given widths with one row per sample
SCHEMA = {
    "format": "excavsim-demonstration",
    "version": SCHEMA_VERSION,
    "fields": {
        "times": "N numbers [s], strictly increasing, uniform at dt",
        "pose": "N x 3 numbers: tip x [m], z [m], pitch [rad] in the arm plane",
        "force": "N x 2 numbers: the environment's force on the bucket, radial and vertical [N]",
        "dt": "positive number: the sample period [s]",
        "waist": "number: the waist angle of the arm plane [rad]",
        "source": "text: where the demonstration came from",
        "soil": "text: the demonstration environment",
    },
}


@dataclasses.dataclass(frozen=True)
class Demonstration:
    """A demonstrated dig: tip pose and measured tip force in the arm plane at a uniform rate.

    Attributes:
        times: (N,) [s] from the first sample, uniform at ``dt``.
        pose: (N, 3) tip x, z [m], pitch [rad].
        force: (N, 2) the environment's force on the bucket, radial (along the arm plane's x) and
            vertical [N] (the F/T sign: the force ON the bucket).
        dt: sample period [s] (the control period of the executor that recorded it).
        waist: waist angle of the arm plane [rad].
        source, soil: provenance.
    """

    times: np.ndarray
    pose: np.ndarray
    force: np.ndarray
    dt: float
    waist: float
    source: str = ""
    soil: str = ""

    def __post_init__(self):
        validate(self.to_dict())

    def to_dict(self) -> dict:
        return {"format": SCHEMA["format"], "version": SCHEMA_VERSION,
                "times": np.asarray(self.times, float).tolist(), "pose": np.asarray(self.pose, float).tolist(),
                "force": np.asarray(self.force, float).tolist(), "dt": float(self.dt), "waist": float(self.waist),
                "source": str(self.source), "soil": str(self.soil)}

    def save(self, path: str | Path) -> Path:
        path = Path(path)
        path.write_text(json.dumps(self.to_dict()))
        return path

    def with_approach(self, height_m: float, duration_s: float) -> Demonstration:
        """The demonstration with a free-motion descent prepended: from ``height_m`` above its first
        pose straight down to it in ``duration_s``, with zero force (the bucket in the air)."""
        n = max(1, int(round(duration_s / self.dt)))
        s = np.linspace(0.0, 1.0, n, endpoint=False)[:, None]
        top = self.pose[0] + np.array([0.0, height_m, 0.0])
        pre = top + s * (self.pose[0] - top)
        pose = np.concatenate([pre, self.pose])
        force = np.concatenate([np.zeros((n, 2)), self.force])
        times = np.arange(len(pose)) * self.dt
        return Demonstration(times, pose, force, self.dt, self.waist, self.source + f" + {height_m:g} m approach",
                             self.soil)


def validate(doc: dict, source: str = "demonstration") -> None:
    """Check a demonstration document against :data:`SCHEMA`; raises :class:`DataFileError` saying what
    is wrong, after ``source`` (the file, when read from one)."""
    if not isinstance(doc, dict):
        raise DataFileError(f"{source}: expected a JSON object, got {type(doc).__name__}")
    if doc.get("format") != SCHEMA["format"] or doc.get("version") != SCHEMA_VERSION:
        raise DataFileError(f"{source}: format/version must be {SCHEMA['format']!r}/{SCHEMA_VERSION}, "
                            f"got {doc.get('format')!r}/{doc.get('version')!r}")
    missing = [k for k in SCHEMA["fields"] if k not in doc]
    extra = [k for k in doc if k not in SCHEMA["fields"] and k not in ("format", "version")]
    if missing or extra:
        raise DataFileError(f"{source}: missing keys {missing}, unknown keys {extra}")
    try:
        times = np.asarray(doc["times"], dtype=float)
        pose = np.asarray(doc["pose"], dtype=float)
        force = np.asarray(doc["force"], dtype=float)
        dt, waist = float(doc["dt"]), float(doc["waist"])
    except (TypeError, ValueError, OverflowError, RecursionError) as exc:
        raise DataFileError(f"{source}: non-numeric data ({type(exc).__name__}: {shorten(exc)})") from None
    n = times.shape[0] if times.ndim == 1 else -1
    if n < 2 or pose.shape != (n, 3) or force.shape != (n, 2):
        raise DataFileError(f"{source}: times (N,), pose (N, 3), force (N, 2) with N >= 2 expected, got "
                            f"{times.shape}, {pose.shape}, {force.shape}")
    if not all(np.all(np.isfinite(a)) for a in (times, pose, force)) or not (math.isfinite(waist) and dt > 0):
        raise DataFileError(f"{source}: every number must be finite and dt positive")
    if not np.allclose(np.diff(times), dt, rtol=1e-6, atol=1e-9):
        raise DataFileError(f"{source}: times must be uniform at dt = {dt} s")
    if not isinstance(doc["source"], str) or not isinstance(doc["soil"], str):
        raise DataFileError(f"{source}: source and soil must be text")


def load_demonstration(path: str | Path) -> Demonstration:
    """Read and validate a demonstration file (:data:`SCHEMA`)."""
    try:
        doc = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError) as exc:  # unreadable, not UTF-8, not JSON, nested too deep
        raise DataFileError(f"demonstration {path}: cannot read ({type(exc).__name__}: {exc})") from None
    validate(doc, f"demonstration {path}")
    return Demonstration(np.asarray(doc["times"], float), np.asarray(doc["pose"], float),
                         np.asarray(doc["force"], float), doc["dt"], doc["waist"], doc["source"], doc["soil"])


def plane_force(force_world: np.ndarray, waist: float, waist_sign: float) -> np.ndarray:
    """A world force (..., 3) in the arm plane at ``waist``: (radial, vertical) (..., 2) [N]."""
    phi = waist_sign * waist
    f = np.asarray(force_world, dtype=float)
    return np.stack([f[..., 0] * math.cos(phi) + f[..., 1] * math.sin(phi), f[..., 2]], axis=-1)


def plane_state(arm: PlanarArm, ft: ForceSensor, obs: Observation, waist: float,
                buf: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What the mind senses in the arm plane: the tip pose (3,) [m, m, rad] and velocity (2,) [m/s] from
    the joints, and the F/T force on the bucket (radial, vertical) (2,) [N]; ``buf`` (4, 3) is scratch."""
    q = obs.q[1:4]
    tip = arm.forward(q)
    vel = (arm.jacobian(q) @ obs.qdot[1:4])[:2]
    ft.reading_into(obs, buf)
    return tip, vel, plane_force(buf[2], waist, arm.waist_sign)


def demonstration_from_record(rec: ExecutionRecord, *, arm: PlanarArm, ft: ForceSensor, waist: float, dt: float,
                              source: str = "executor record", soil: str = "") -> Demonstration:
    """The cut of an executed dig as a demonstration.

    The executor logs the tip pose every control step from the start of the cut to the tick before
    the lift-out starts (``executed_path``, the stall's back-out included), so the samples' times are
    ``phase_starts["lift out"] - (N - k) dt``. The F/T trace (tip frame, at the F/T rate) is
    interpolated onto them and rotated into the arm plane with the tip frame at each pose (IK of the
    pose, the sensor's own kinematic model).

    Raises:
        ExcavsimError: the record has no cut or no lift-out.
    """
    if len(rec.executed_path) < 2 or "lift out" not in rec.phase_starts or len(rec.ft) < 2:
        raise UsageError(f"demonstration: the record has no cut to demonstrate (outcome {rec.outcome!r})")
    pose = np.asarray(rec.executed_path, dtype=float)
    n = len(pose)
    t = rec.phase_starts["lift out"] - (n - np.arange(n)) * dt
    ft_t = np.array([s[0] for s in rec.ft])
    ft_f = np.array([s[1] for s in rec.ft])
    f_tip = np.stack([np.interp(t, ft_t, ft_f[:, k]) for k in range(3)], axis=-1)
    q_arm, ok = arm.inverse(pose)
    force = np.zeros((n, 2))
    for i in range(n):
        q = np.array([waist, *(q_arm[i] if ok[i] else q_arm[max(i - 1, 0)]), 0.0, 0.0])
        force[i] = plane_force(ft.frames(q)["tip_rot"] @ f_tip[i], waist, arm.waist_sign)
    return Demonstration(np.arange(n) * dt, pose, force, dt, waist, source, soil)


def demonstration_from_joints(joint_times: np.ndarray, joints: np.ndarray, ft_times: np.ndarray, ft_tip: np.ndarray,
                              path_world: np.ndarray, *, arm: PlanarArm, ft: ForceSensor, dt: float,
                              source: str = "recording", soil: str = "") -> Demonstration:
    """The cut of a dig from sampled joint angles and F/T readings (e.g. read back from a Rerun recording).

    The cut path has one point per control step (the executor's ``executed_path``), so the cut ends at the
    joint sample whose tip (forward kinematics) is nearest the path's last point and began ``(P - 1) dt``
    before (the tip rests at the path's first point during touch-down, so its nearest sample would not
    date the start); joint angles and F/T readings are
    interpolated linearly onto a uniform grid at ``dt`` (the recording's joint rate, 10 Hz by default,
    is coarser than the control rate: the demonstration is smoother than the executed cut), the pose
    is the forward kinematics of the interpolated joints and the force is rotated from the tip frame
    into the arm plane at each pose.

    Args:
        joint_times: (N,) [s]; joints: (N, 6) [rad]; ft_times: (M,) [s]; ft_tip: (M, 3) tip-frame force [N];
        path_world: (P, 3) the measured cut path in world coordinates [m].

    Raises:
        ExcavsimError: the cut is shorter than two samples.
    """
    joints = np.asarray(joints, dtype=float)
    waist = float(np.median(joints[:, 0]))
    tips = arm.forward(joints[:, 1:4])
    world = arm.plane_to_world(joints[:, 0], tips[:, :2])
    t1 = joint_times[int(np.argmin(np.linalg.norm(world - path_world[-1], axis=1)))]
    t0 = max(t1 - (len(path_world) - 1) * dt, joint_times[0])
    n = int(np.floor((t1 - t0) / dt + 1e-9)) + 1
    if n < 2:
        raise UsageError(f"demonstration: the recorded cut spans {t1 - t0:.3f} s, shorter than two samples")
    t = t0 + np.arange(n) * dt
    q = np.stack([np.interp(t, joint_times, joints[:, k]) for k in range(joints.shape[1])], axis=-1)
    f_tip = np.stack([np.interp(t, ft_times, ft_tip[:, k]) for k in range(3)], axis=-1)
    pose = arm.forward(q[:, 1:4])
    force = np.array([plane_force(ft.frames(q[i])["tip_rot"] @ f_tip[i], waist, arm.waist_sign) for i in range(n)])
    return Demonstration(np.arange(n) * dt, pose, force, dt, waist, source, soil)
