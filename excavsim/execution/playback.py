"""Programming digs by demonstration and playing them back with variable impedance (DiMaio ch. 3, 6).

Source: 002_694c274da322d931.txt, ch. 3 (§3.1 recording and playback in dissimilar environments,
§3.2 the duality principle, §3.3 the generalised duality principle, §3.3.2 the position-force error
weighting, §3.3.3-3.3.4 the environment impedance from the force/velocity ratio), ch. 6 and App. A.2.

**Demonstration** (:class:`Demonstration`): a time series of the bucket-tip pose in the arm plane
(x, z, pitch) and the environment's force on the bucket in the arm plane (radial, vertical), taken
from an executor record (:func:`demonstration_from_record`: the tip path logged every control step
in the cut and the F/T trace, rotated from the tip frame into the plane). Stored as JSON with a
schema (:data:`SCHEMA`) that :func:`load_demonstration` checks on load.

**Playback** (:class:`ImpedancePlayback`): at the control rate, each of the plane's axes x, z runs
the machine impedance of eq. 3.15, ``Mm xc'' = f0 + fe - Bm (xc' - x0') - Km (xc - x0)``, with x0
the demonstrated position, f0 = -fe_demo the demonstrated *applied* force (in the demonstration
environment a perfect track has fe = -f0, eq. 3.10 at x = x0) and fe the measured F/T force. It is
discretised by the backward difference of App. A.2 (eq. A.76) and realised as an admittance: xc is
the commanded tip position, turned into joint targets by IK for the T3's position servos; the pitch
follows the demonstration. Three impedance laws (:class:`FixedImpedance`, :class:`VariableImpedance`):

* fixed high impedance (position control, Table 6.5's upper stiffness, Fig. 6.42),
* fixed low impedance (force-dominant, Table 6.5's lower stiffness, Fig. 6.43),
* variable impedance (§3.3.4, eq. 3.37): per axis the stiffness is interpolated between its bounds
  from the force/velocity ratio ``|fe| / (G |v_m|)`` (the environment impedance estimate,
  :class:`ForceVelocityEstimate`), with G the velocity weighting (the position-force weighting of
  §3.3.2 in eq. 3.37's form); the damping follows from the damping factor, ``B = 2 zeta sqrt(K M)``
  (Table 6.5: K = 1e5 N/m, M = 100 kg, zeta = 1 gives the 6324 N s/m of §6.2).

The duality relations themselves are here as functions the tests check on a 1-D mass-spring-damper:
:func:`static_response` (eqs. 3.17-3.18), :func:`weighted_error` (eq. 3.14) and :func:`dual_stiffness`
(eq. 3.21, ``Km = W / Ke``).

Assumed (the thesis is silent or its text is garbled): eq. 3.37's interpolation weight is read as
``lambda = 1 - r / 2`` for ``r = |fe| / (G |v|) <= 1`` and ``lambda = 1 / (2 r)`` for ``r > 1`` (continuous
and monotone, lambda -> 1 in free motion, -> 0 against hard contact), with lambda unchanged while
both ``|fe|`` and ``G |v|`` are below ``f_min``; lambda is low-passed with ``lambda_tau_s`` against the
F/T noise; the demonstrated force is low-passed at ``force_bandwidth_hz`` (eq. 3.26's first-order
filter, applied to the force only so that the position is not delayed); the machine mass is a
virtual admittance mass (the T3's servos are position servos, so Mm is chosen, not measured).
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np

from excavsim.errors import ExcavsimError
from excavsim.handoff.dig import ExecutionRecord
from excavsim.handoff.observation import Observation, Servos
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


def validate(doc: dict) -> None:
    """Check a demonstration document against :data:`SCHEMA`; raises :class:`ExcavsimError` saying what is wrong."""
    if not isinstance(doc, dict):
        raise ExcavsimError(f"demonstration: expected a JSON object, got {type(doc).__name__}")
    if doc.get("format") != SCHEMA["format"] or doc.get("version") != SCHEMA_VERSION:
        raise ExcavsimError(f"demonstration: format/version must be {SCHEMA['format']!r}/{SCHEMA_VERSION}, "
                            f"got {doc.get('format')!r}/{doc.get('version')!r}")
    missing = [k for k in SCHEMA["fields"] if k not in doc]
    extra = [k for k in doc if k not in SCHEMA["fields"] and k not in ("format", "version")]
    if missing or extra:
        raise ExcavsimError(f"demonstration: missing keys {missing}, unknown keys {extra}")
    try:
        times = np.asarray(doc["times"], dtype=float)
        pose = np.asarray(doc["pose"], dtype=float)
        force = np.asarray(doc["force"], dtype=float)
        dt, waist = float(doc["dt"]), float(doc["waist"])
    except (TypeError, ValueError) as exc:
        raise ExcavsimError(f"demonstration: non-numeric data ({exc})") from None
    n = times.shape[0] if times.ndim == 1 else -1
    if n < 2 or pose.shape != (n, 3) or force.shape != (n, 2):
        raise ExcavsimError(f"demonstration: times (N,), pose (N, 3), force (N, 2) with N >= 2 expected, got "
                            f"{times.shape}, {pose.shape}, {force.shape}")
    if not all(np.all(np.isfinite(a)) for a in (times, pose, force)) or not (math.isfinite(waist) and dt > 0):
        raise ExcavsimError("demonstration: every number must be finite and dt positive")
    if not np.allclose(np.diff(times), dt, rtol=1e-6, atol=1e-9):
        raise ExcavsimError(f"demonstration: times must be uniform at dt = {dt} s")
    if not isinstance(doc["source"], str) or not isinstance(doc["soil"], str):
        raise ExcavsimError("demonstration: source and soil must be text")


def load_demonstration(path: str | Path) -> Demonstration:
    """Read and validate a demonstration file (:data:`SCHEMA`)."""
    try:
        doc = json.loads(Path(path).read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise ExcavsimError(f"demonstration {path}: cannot read ({exc})") from None
    validate(doc)
    return Demonstration(np.asarray(doc["times"], float), np.asarray(doc["pose"], float),
                         np.asarray(doc["force"], float), doc["dt"], doc["waist"], doc["source"], doc["soil"])


def plane_force(force_world: np.ndarray, waist: float, waist_sign: float) -> np.ndarray:
    """A world force (..., 3) in the arm plane at ``waist``: (radial, vertical) (..., 2) [N]."""
    phi = waist_sign * waist
    f = np.asarray(force_world, dtype=float)
    return np.stack([f[..., 0] * math.cos(phi) + f[..., 1] * math.sin(phi), f[..., 2]], axis=-1)


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
        raise ExcavsimError(f"demonstration: the record has no cut to demonstrate (outcome {rec.outcome!r})")
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


# ----------------------------------------------------------------------------------- duality (§3.2-3.3)
def critical_damping(stiffness: float | np.ndarray, mass: float, zeta: float = 1.0) -> float | np.ndarray:
    """Damping ``B = 2 zeta sqrt(K M)`` (Table 6.5's damping factor; §6.2: K = 1e5, M = 100 -> 6324 N s/m)."""
    return 2.0 * zeta * np.sqrt(np.asarray(stiffness, dtype=float) * mass)


def static_response(f0: float, x0: float, km: float, ke: float) -> tuple[float, float]:
    """Eqs. 3.17-3.18: the steady position x and the force the manipulator applies to a spring
    environment ``Ke`` (``-fe = Ke x``) under the impedance ``Km`` with desired position x0 and force f0."""
    x = (f0 + km * x0) / (km + ke)
    return x, ke * x


def weighted_error(w: float, x_err: float | np.ndarray, f_err: float | np.ndarray) -> float | np.ndarray:
    """Eq. 3.14: ``E = W (x0 - x)^2 + (f0 - f)^2``."""
    return w * np.square(x_err) + np.square(f_err)


def dual_stiffness(w: float, ke: float) -> float:
    """Eq. 3.21: the manipulator stiffness minimising eq. 3.14 in the static case, ``Km = W / Ke``."""
    return w / ke


def lambda_from_ratio(f: float, gv: float, f_min: float, previous: float) -> float:
    """Eq. 3.37's interpolation weight from ``|fe|`` and ``G |v_m|`` (assumed reading, see the module docstring)."""
    if f > gv and f > f_min:
        return 0.5 * gv / f
    if gv >= f and gv > f_min:
        return 1.0 - 0.5 * f / gv
    return previous


class ForceVelocityEstimate:
    """The environment impedance magnitude from the force/velocity ratio (§3.3.4), per axis, low-passed.

    ``update(f, v)`` with the force on the machine and its velocity (arrays of the axes) returns
    ``|Ze| ~ |f| / |v|``; axes whose velocity is below ``v_min`` keep their estimate.
    """

    def __init__(self, n: int, *, dt: float, tau_s: float = 0.1, v_min: float = 1e-3):
        self.z = np.full(n, np.nan)
        self.alpha = dt / (tau_s + dt)
        self.v_min = v_min

    def update(self, f: np.ndarray, v: np.ndarray) -> np.ndarray:
        f, v = np.abs(np.asarray(f, float)), np.abs(np.asarray(v, float))
        moving = v > self.v_min
        ratio = np.where(moving, f / np.maximum(v, self.v_min), np.nan)
        fresh = np.isnan(self.z) & moving
        self.z = np.where(fresh, ratio, self.z)
        self.z = np.where(moving & ~fresh, self.z + self.alpha * (ratio - self.z), self.z)
        return self.z.copy()


# ----------------------------------------------------------------------------------- impedance laws
@dataclasses.dataclass
class FixedImpedance:
    """A fixed machine impedance per axis (Figs. 6.42-6.44)."""

    name: str
    mass: float
    stiffness: float
    zeta: float = 1.0

    def reset(self, n: int, dt: float) -> None:
        self.n = n

    def gains(self, f: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        k = np.full(self.n, self.stiffness)
        return k, critical_damping(k, self.mass, self.zeta)


@dataclasses.dataclass
class VariableImpedance:
    """The variable impedance of §3.3.4 (eq. 3.37): stiffness between ``k_min`` and ``k_max`` from
    the force/velocity ratio weighted by ``G`` [N s/m]; damping by the damping factor."""

    name: str
    mass: float
    k_min: float
    k_max: float
    g: float
    f_min: float = 20.0
    zeta: float = 1.0
    lambda_tau_s: float = 0.05

    def reset(self, n: int, dt: float) -> None:
        self.lam = np.ones(n)  # start stiff: in the air
        self.alpha = dt / (self.lambda_tau_s + dt)

    def gains(self, f: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        for k in range(len(self.lam)):
            target = lambda_from_ratio(abs(f[k]), self.g * abs(v[k]), self.f_min, self.lam[k])
            self.lam[k] += self.alpha * (target - self.lam[k])
        k = self.k_min + self.lam * (self.k_max - self.k_min)
        return k, critical_damping(k, self.mass, self.zeta)


class Admittance:
    """Eq. 3.15 per axis, discretised by the backward difference of App. A.2 (eq. A.76):

    ``x_k = [(2M + BT) x_{k-1} - M x_{k-2} + T^2 (f0 + fe)_k + (BT + KT^2) x0_k - BT x0_{k-1}] / (M + BT + KT^2)``.
    """

    def __init__(self, x0: np.ndarray, mass: float, dt: float):
        self.x1 = np.array(x0, dtype=float)
        self.x2 = self.x1.copy()
        self.x0_1 = self.x1.copy()
        self.m, self.t = mass, dt

    def step(self, x0: np.ndarray, f0: np.ndarray, fe: np.ndarray, k: np.ndarray, b: np.ndarray) -> np.ndarray:
        m, t = self.m, self.t
        x = ((2 * m + b * t) * self.x1 - m * self.x2 + t * t * (f0 + fe) + (b * t + k * t * t) * x0
             - b * t * self.x0_1) / (m + b * t + k * t * t)
        self.x2, self.x1, self.x0_1 = self.x1, x, np.array(x0, dtype=float)
        return x


@dataclasses.dataclass
class PlaybackRun:
    """One playback: per control step the demonstration's values, the commanded and measured tip, the
    measured plane force and the machine stiffness (x, z) [s, m, rad, N, N/m]."""

    controller: str
    soil: str
    times: np.ndarray
    desired_pose: np.ndarray
    desired_force: np.ndarray
    command: np.ndarray
    pose: np.ndarray
    force: np.ndarray
    stiffness: np.ndarray
    outcome: str = "completed"

    def errors(self, w: float) -> dict[str, float]:
        """Trajectory errors against the demonstration: RMS and largest tip distance [m], RMS and largest
        force error magnitude [N], largest force magnitude [N], and eq. 3.14's mean ``W x~^2 + f~^2``."""
        dx = np.linalg.norm(self.pose[:, :2] - self.desired_pose[:, :2], axis=1)
        df = np.linalg.norm(self.force - self.desired_force, axis=1)
        return {"pos_rms_m": float(np.sqrt(np.mean(dx ** 2))), "pos_max_m": float(dx.max()),
                "force_rms_n": float(np.sqrt(np.mean(df ** 2))), "force_max_err_n": float(df.max()),
                "force_peak_n": float(np.linalg.norm(self.force, axis=1).max()),
                "demo_force_peak_n": float(np.linalg.norm(self.desired_force, axis=1).max()),
                "weighted_error": float(np.mean(weighted_error(w, dx, df)))}


class ImpedancePlayback:
    """Plays a :class:`Demonstration` back on the arm at the control rate (see the module docstring).

    Args:
        sim: the servos (the world's Simulation seen as :class:`Servos`).
        arm: the planar kinematics; ft: the wrist F/T sensor reporting at the tip.
        law: :class:`FixedImpedance` or :class:`VariableImpedance`.
        force_bandwidth_hz: eq. 3.26's first-order filter on the demonstrated force (assumed value).
    """

    def __init__(self, sim: Servos, arm: PlanarArm, ft: ForceSensor, law, *, force_bandwidth_hz: float = 5.0):
        self.sim, self.arm, self.ft, self.law = sim, arm, ft, law
        self.force_bandwidth_hz = force_bandwidth_hz
        self._ftw = np.zeros((4, 3))

    def _plane(self, obs: Observation, waist: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        q = obs.q[1:4]
        tip = self.arm.forward(q)
        vel = (self.arm.jacobian(q) @ obs.qdot[1:4])[:2]
        self.ft.reading_into(obs, self._ftw)
        return tip, vel, plane_force(self._ftw[2], waist, self.arm.waist_sign)

    def run(self, demo: Demonstration, soil: str = "") -> PlaybackRun:
        """Play ``demo`` from the arm's current pose (it should be at the demonstration's start)."""
        sim, dt = self.sim, self.sim.control_dt
        if abs(dt - demo.dt) > 1e-9:
            raise ExcavsimError(f"playback: the demonstration's dt {demo.dt} s is not the control period {dt} s")
        n = len(demo.times)
        law = self.law
        law.reset(2, dt)
        obs = sim.observe()
        adm = Admittance(demo.pose[0, :2], law.mass, dt)
        a_f = 1.0 - math.exp(-2 * math.pi * self.force_bandwidth_hz * dt)
        f0 = -demo.force[0].copy()
        out = {k: np.zeros((n, m)) for k, m in (("command", 3), ("pose", 3), ("force", 2), ("stiffness", 2))}
        target = obs.q.copy()
        outcome = "completed"
        for i in range(n):
            tip, vel, fe = self._plane(obs, demo.waist)
            f0 += a_f * (-demo.force[i] - f0)
            k, b = law.gains(fe, vel)
            xc = adm.step(demo.pose[i, :2], f0, fe, k, b)
            cmd = np.array([xc[0], xc[1], demo.pose[i, 2]])
            q, ok = self.arm.inverse(cmd)
            if ok:
                target[1:4] = q
            target[0], target[4], target[5] = demo.waist, 0.0, 0.0
            out["command"][i], out["pose"][i], out["force"][i], out["stiffness"][i] = cmd, tip, fe, k
            try:
                obs = sim.track(target)
            except ExcavsimError as exc:
                outcome = f"simulation failure: {exc}"
                for key in out:
                    out[key] = out[key][:i + 1]
                n = i + 1
                break
        return PlaybackRun(law.name, soil, demo.times[:n].copy(), demo.pose[:n].copy(), demo.force[:n].copy(),
                           out["command"], out["pose"], out["force"], out["stiffness"], outcome)
