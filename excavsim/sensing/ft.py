"""The wrist force/torque sensor as the robot's mind reads it (Singh 1995 §7.1.3).

On the testbed a JR3 six-axis sensor sits between the wrist and the bucket; its processor was
"programmed to register forces with respect to the tip of the bucket" (Fig. 103), and a dedicated
process recorded readings at about 10 Hz. :class:`ForceSensor` does the same with what the robot
knows: the raw wrist reading of an :class:`~excavsim.handoff.observation.Observation`, the measured
joint angles, and its own kinematic model (the compiled ``MjModel`` with a private ``MjData``; never
the simulation's data).

Conventions:

* The raw reading (``Observation.ft_force``/``ft_torque``, MuJoCo's ``force``/``torque`` sensors at
  the ``ft_mount`` site) is the force and moment the *wrist exerts on the bucket*, moment about the
  ``ft_mount`` origin, in the ``ft_mount`` frame. It includes the bucket's own weight.
* :class:`FTReading` reports the wrench of the *environment (soil and load) on the bucket*: positive
  components are the force the soil exerts ON the bucket. Moments are about the bucket tip (the
  centre of the cutting edge, site ``bucket_tip``). The tip frame (Fig. 103): x along the blade from
  heel to cutting edge, z normal to the blade pointing into the bucket, y = z × x. So a bucket
  dragged through soil towards the robot (cutting edge leading) reads a force pointing backwards,
  away from the robot: negative ``force_tip[0]`` (-x_tip); in sand it also reads negative
  ``force_tip[2]`` (the wedge pushes on the blade's outer face, eq. 8 direction
  ``-sin δ x_tip - cos δ z_tip``).
* The load of soil carried in the bucket is part of the environment: its weight shows in the
  reading, as it did on the testbed's sensor once the tool was tared.

The conversion is a static balance of the bucket (the sensor's gravity compensation for a known
tool): ``F_env = -F_wrist - m g`` and, about the tip point t, ``M_env = -M_wrist - (s - t) × F_wrist
- (c - t) × m g`` with s the sensor origin, c the bucket's centre of mass and m its mass, both read
from the model. The bucket's acceleration is ignored (as in the thesis' statics, App. 2): while the
arm accelerates, the reading is off by the bucket's inertial force ``m a`` (28 kg × a).

Speed: the executor reads the sensor every control step. :meth:`ForceSensor.reading_into` does the
validation and the balance in compiled code (:func:`wrench_kernel`) around MuJoCo's kinematics,
with the arithmetic of the numpy reference (:func:`environment_wrench`, which :meth:`ForceSensor.reading`
keeps using): the same products and sums in the same order, and for the rotation into world axes
the fused multiply-adds of the BLAS product numpy calls. The rotation back into the tip frame
(``tip_rot.T @ v``) rounds differently with the CPU numpy's BLAS picks its kernels for: a plain sum
in order on some, a chain of fused multiply-adds on others (OpenBLAS's SkylakeX ``dgemv_t``);
:func:`compiled_order` finds on first use which of the kernel's orders gives numpy's numbers bit for
bit on this machine (:func:`compiled_matches_numpy`: one does); where none does, the sensor computes
with numpy instead. Either way a reading is the numpy reference's, to the bit.
"""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numba
import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from excavsim import constants
from excavsim.config import ForceSensorConfig
from excavsim.errors import ConfigError, ModelError, UsageError, WorldError
from excavsim.handoff.observation import Observation
from excavsim.readouts import element_id


@dataclasses.dataclass(frozen=True)
class FTReading:
    """One F/T reading: the environment's (soil + load) wrench on the bucket, about the bucket tip.

    Sign: positive components are the force the soil exerts ON the bucket; a bucket dragged towards
    the robot through soil reads a force backwards, away from the robot, i.e. along -x_tip.

    Attributes:
        time: time of the observation the reading came from [s].
        force_tip: (3,) force in the tip frame (x_tip, y_tip, z_tip) [N].
        torque_tip: (3,) moment about the tip point, in the tip frame [N m].
        force_world: (3,) the same force in world axes [N].
        torque_world: (3,) the same moment about the tip point, in world axes [N m].
    """

    time: float
    force_tip: np.ndarray
    torque_tip: np.ndarray
    force_world: np.ndarray
    torque_world: np.ndarray


def environment_wrench(sensor_force: np.ndarray, sensor_torque: np.ndarray, *, sensor_rot: np.ndarray,
                       sensor_pos: np.ndarray, tip_rot: np.ndarray, tip_pos: np.ndarray, com: np.ndarray,
                       weight: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The environment's wrench on a tool about its tip, from a wrist sensor reading (static balance).

    All arguments broadcast over leading dimensions ``(...)``.

    Args:
        sensor_force: (..., 3) force of the wrist on the tool, sensor frame [N].
        sensor_torque: (..., 3) moment of the wrist on the tool about the sensor origin, sensor frame [N m].
        sensor_rot: (..., 3, 3) sensor frame orientation (columns = sensor axes in world).
        sensor_pos: (..., 3) sensor origin, world [m].
        tip_rot: (..., 3, 3) tip frame orientation (columns = tip axes in world).
        tip_pos: (..., 3) tip point, world [m].
        com: (..., 3) the tool's centre of mass, world [m].
        weight: (..., 3) the tool's weight ``m g``, world [N].

    Returns:
        ``(force_tip, torque_tip, force_world, torque_world)``, each (..., 3): the environment's force
        on the tool and its moment about the tip point, in the tip frame and in world axes.
    """
    if sensor_force.ndim == 1 and sensor_rot.ndim == 2 and tip_rot.ndim == 2:  # one reading: no broadcasting
        f_wrist = sensor_rot @ sensor_force
        m_wrist = sensor_rot @ sensor_torque
        f_env = -f_wrist - weight
        m_env = -m_wrist - _cross3(sensor_pos - tip_pos, f_wrist) - _cross3(com - tip_pos, weight)
        return tip_rot.T @ f_env, tip_rot.T @ m_env, f_env, m_env
    f_wrist = np.einsum("...ij,...j->...i", sensor_rot, sensor_force)
    m_wrist = np.einsum("...ij,...j->...i", sensor_rot, sensor_torque)
    f_env = -f_wrist - weight
    m_env = -m_wrist - np.cross(sensor_pos - tip_pos, f_wrist) - np.cross(com - tip_pos, weight)
    force_tip = np.einsum("...ji,...j->...i", tip_rot, f_env)
    torque_tip = np.einsum("...ji,...j->...i", tip_rot, m_env)
    return force_tip, torque_tip, f_env, m_env


def _cross3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product of two 3-vectors (``np.cross`` has a large fixed cost per call for one pair)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


@intrinsic
def _fma(typingctx, a, b, c):
    """``a * b + c`` rounded once (LLVM's fma), as the BLAS kernels numpy's matrix products use."""
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        d = ir.DoubleType()
        fn = builder.module.declare_intrinsic("llvm.fma", [d], ir.FunctionType(d, [d, d, d]))
        return builder.call(fn, args)

    return sig, codegen


@numba.njit(cache=True, inline="always")
def _rot_row(m, off, v0, v1, v2):
    """Row ``off // 3`` of a row-major 3x3 matrix ``m[off:off + 9]`` times (v0, v1, v2), in the order
    of the BLAS ``gemv`` numpy calls for ``(3, 3) @ (3,)``: fma(a2, x2, fma(a0, x0, a1 * x1))."""
    return _fma(m[off + 2], v2, _fma(m[off], v0, m[off + 1] * v1))


TIP_ORDERS = ("plain", "fma")
"""The orders :func:`wrench_kernel` can sum ``tip_rot.T @ v`` in (its ``tip_order`` index): ``"plain"``,
a0 x0 + a1 x1 + a2 x2 rounded after each operation (numpy's own loop); ``"fma"``,
fma(a2, x2, fma(a1, x1, a0 x0)) (OpenBLAS's transposed ``gemv`` on AVX-512 machines)."""


@numba.njit(cache=True, inline="always")
def _tip_row(m, k, v0, v1, v2, tip_order):
    """Column ``k`` of a row-major 3x3 matrix ``m`` dotted with (v0, v1, v2), in order ``tip_order``
    (an index into :data:`TIP_ORDERS`)."""
    if tip_order == 1:
        return _fma(m[6 + k], v2, _fma(m[3 + k], v1, m[k] * v0))
    return m[k] * v0 + m[3 + k] * v1 + m[6 + k] * v2


@numba.njit(cache=True)
def wrench_kernel(force, torque, xmat, xpos, com, ft_site, tip_site, bucket, weight, out, tip_order=0):
    """The environment's wrench about the tip from one wrist reading, as :func:`environment_wrench`
    computes it for one reading (same operations, same order), straight from MuJoCo's arrays.

    Args:
        force, torque: (3,) the wrist reading (sensor frame) [N, N m].
        xmat, xpos: ``site_xmat`` (nsite, 9) and ``site_xpos`` (nsite, 3) of the sensor's MjData.
        com: ``subtree_com`` (nbody, 3); ft_site, tip_site, bucket: the sensor site, tip site and bucket body.
        weight: (3,) the bucket's weight [N].
        out: (4, 3) written: force_tip, torque_tip, force_world, torque_world.
        tip_order: how ``tip_rot.T @ v`` is summed (an index into :data:`TIP_ORDERS`; :func:`compiled_order`
            gives the one that equals numpy's on this machine).

    Returns:
        False (and ``out`` untouched) when the reading is not finite.
    """
    for k in range(3):
        if not (math.isfinite(force[k]) and math.isfinite(torque[k])):
            return False
    sr = xmat[ft_site]
    tr = xmat[tip_site]
    fw = np.empty(3)
    mw = np.empty(3)
    for k in range(3):
        fw[k] = _rot_row(sr, 3 * k, force[0], force[1], force[2])
        mw[k] = _rot_row(sr, 3 * k, torque[0], torque[1], torque[2])
    fe = np.empty(3)
    sp = np.empty(3)
    cp = np.empty(3)
    for k in range(3):
        fe[k] = -fw[k] - weight[k]
        sp[k] = xpos[ft_site, k] - xpos[tip_site, k]
        cp[k] = com[bucket, k] - xpos[tip_site, k]
    for k in range(3):
        i, j = (k + 1) % 3, (k + 2) % 3
        c1 = sp[i] * fw[j] - sp[j] * fw[i]
        c2 = cp[i] * weight[j] - cp[j] * weight[i]
        out[3, k] = -mw[k] - c1 - c2
        out[2, k] = fe[k]
    for k in range(3):  # tip_rot.T @ v, in the machine's order
        out[0, k] = _tip_row(tr, k, fe[0], fe[1], fe[2], tip_order)
        out[1, k] = _tip_row(tr, k, out[3, 0], out[3, 1], out[3, 2], tip_order)
    return True


@numba.njit(cache=True)
def _finite_q(q, qpos, qadr):
    """Write the joint angles ``q`` into ``qpos`` at ``qadr``; False (nothing written) if one is not finite."""
    for k in range(q.shape[0]):
        if not math.isfinite(q[k]):
            return False
    for k in range(q.shape[0]):
        qpos[qadr[k]] = q[k]
    return True


_ORDER: list[int] = []


def compiled_order(n: int = 2000) -> int:
    """The :data:`TIP_ORDERS` index with which :func:`wrench_kernel` gives :func:`environment_wrench`'s
    numbers bit for bit on this machine, or -1 when no order does (checked once, on ``n`` random
    readings and frames; the BLAS kernel numpy's matrix product runs, and so its rounding, depends
    on the CPU)."""
    if not _ORDER:
        rng = np.random.default_rng(17)
        cases = []
        for _ in range(n):
            rot = [rng.normal(size=(3, 3)) for _ in range(2)]
            xmat = np.stack([r.ravel() for r in rot])
            xpos = rng.normal(size=(2, 3))
            com, weight = rng.normal(size=(1, 3)), rng.normal(size=3) * 300.0
            f, t = rng.normal(size=3) * 500.0, rng.normal(size=3) * 200.0
            ref = environment_wrench(f, t, sensor_rot=rot[0], sensor_pos=xpos[0], tip_rot=rot[1], tip_pos=xpos[1],
                                     com=com[0], weight=weight)
            cases.append((f, t, xmat, xpos, com, weight, ref))
        out = np.empty((4, 3))
        found = -1
        for order in range(len(TIP_ORDERS)):
            ok = True
            for f, t, xmat, xpos, com, weight, ref in cases:
                wrench_kernel(f, t, xmat, xpos, com, 0, 1, 0, weight, out, order)
                if not all(np.array_equal(r, o) for r, o in zip(ref, out)):
                    ok = False
                    break
            if ok:
                found = order
                break
        _ORDER.append(found)
    return _ORDER[0]


def compiled_matches_numpy(n: int = 2000) -> bool:
    """Whether :func:`wrench_kernel`, in one of its orders (:func:`compiled_order`), gives
    :func:`environment_wrench`'s numbers bit for bit on this machine."""
    return compiled_order(n) >= 0


class ForceSensor:
    """The wrist F/T sensor programmed to report the soil's wrench at the bucket tip, at a fixed rate.

    Args:
        model: the compiled scene (the robot's kinematic model; read, never stepped).
        rate_hz: sample rate of :meth:`sample` [Hz] (the testbed's process ran at about 10 Hz).
        joints: the joints an observation's ``q`` lists, in its order (default the T3's six; an
            excavator's swing, boom, stick and bucket).

    Raises:
        ExcavsimError: ``rate_hz`` is not a positive finite number.
        ModelError: the model lacks the bucket, its sites or an arm joint.
    """

    def __init__(self, model: mujoco.MjModel, *, rate_hz: float = 10.0, joints: tuple[str, ...] = constants.JOINTS):
        try:
            rate = float(rate_hz)
        except (TypeError, ValueError):
            rate = math.nan
        if not (math.isfinite(rate) and rate > 0.0):
            raise ConfigError(f"ForceSensor rate_hz must be a positive finite number [Hz], got {rate_hz!r}")
        self.rate_hz = rate
        self.period_s = 1.0 / rate
        self.model = model
        self._data = mujoco.MjData(model)  # private: the mind's own kinematic state
        self._bucket = element_id(model, "body", constants.BUCKET_BODY)
        self._ft_site = element_id(model, "site", constants.FT_SITE)
        self._tip_site = element_id(model, "site", constants.BUCKET_TIP_SITE)
        joints = [element_id(model, "joint", j) for j in joints]
        self._qadr = np.array([model.jnt_qposadr[j] for j in joints])
        if model.site_bodyid[self._ft_site] != self._bucket:
            raise ModelError(f"site {constants.FT_SITE!r} must be on body {constants.BUCKET_BODY!r} "
                             f"(the sensor measures the bucket subtree)")
        self.bucket_mass_kg = float(model.body_subtreemass[self._bucket])
        self._weight = self.bucket_mass_kg * np.asarray(model.opt.gravity, dtype=float)
        # views into the private MjData for the compiled reading (they live as long as ``_data``)
        d = self._data
        self._qpos, self._xmat, self._xpos, self._com = d.qpos, d.site_xmat, d.site_xpos, d.subtree_com
        self._qshape = (len(self._qadr),)
        self._tip_order = compiled_order()
        self._fast = self._tip_order >= 0
        self.reset()

    @classmethod
    def from_config(cls, model: mujoco.MjModel, config: ForceSensorConfig | None = None, *,
                    joints: tuple[str, ...] = constants.JOINTS) -> ForceSensor:
        """A sensor with the rate of ``config`` (the ``force_sensor`` section of ``configs/sensing.yaml``) on a
        machine whose observations list ``joints`` (default the T3's)."""
        config = config or ForceSensorConfig()
        return cls(model, rate_hz=config.rate_hz, joints=joints)

    # -- conversion -----------------------------------------------------------------------------
    def frames(self, q: np.ndarray) -> dict[str, np.ndarray]:
        """The sensor and tip frames and the bucket's centre of mass at joint angles ``q`` (6,) [rad].

        Returns:
            ``sensor_rot`` (3, 3), ``sensor_pos`` (3,), ``tip_rot`` (3, 3), ``tip_pos`` (3,), ``com`` (3,),
            world frame (rotations have the frame's axes as columns).
        """
        d = self._data
        d.qpos[self._qadr] = q
        mujoco.mj_kinematics(self.model, d)
        mujoco.mj_comPos(self.model, d)  # subtree centres of mass
        return {
            "sensor_rot": d.site_xmat[self._ft_site].reshape(3, 3).copy(),
            "sensor_pos": d.site_xpos[self._ft_site].copy(),
            "tip_rot": d.site_xmat[self._tip_site].reshape(3, 3).copy(),
            "tip_pos": d.site_xpos[self._tip_site].copy(),
            "com": d.subtree_com[self._bucket].copy(),
        }

    def reading_into(self, obs: Observation, out: np.ndarray) -> np.ndarray:
        """:meth:`reading`'s four vectors written into ``out`` (4, 3): force_tip, torque_tip,
        force_world, torque_world, equal to it bit for bit; the executor's per-step reading, without
        the copies and the :class:`FTReading`.

        Raises:
            ExcavsimError: as :meth:`reading`.
        """
        q, f, t = getattr(obs, "q", None), getattr(obs, "ft_force", None), getattr(obs, "ft_torque", None)
        if not (self._fast and type(q) is np.ndarray and type(f) is np.ndarray and type(t) is np.ndarray
                and q.dtype == f.dtype == t.dtype == np.float64 and q.shape == self._qshape
                and f.shape == (3,) and t.shape == (3,) and _finite_q(q, self._qpos, self._qadr)
                and math.isfinite(obs.time)):
            r = self.reading(obs)  # the reference: validates (and raises) the same way
            out[0], out[1], out[2], out[3] = r.force_tip, r.torque_tip, r.force_world, r.torque_world
            return out
        mujoco.mj_kinematics(self.model, self._data)
        mujoco.mj_comPos(self.model, self._data)
        if not wrench_kernel(f, t, self._xmat, self._xpos, self._com, self._ft_site, self._tip_site, self._bucket,
                             self._weight, out, self._tip_order):
            _checked(obs, len(self._qadr))  # raises: the reading is not finite
        return out

    def reading(self, obs: Observation) -> FTReading:
        """The environment's wrench on the bucket about its tip, from one observation (static balance).

        Raises:
            ExcavsimError: the observation's time, ``q`` (6,), ``ft_force`` (3,) or ``ft_torque`` (3,)
                are missing, wrongly shaped or not finite.
        """
        time, q, force, torque = _checked(obs, len(self._qadr))
        ft, tt, fw, tw = environment_wrench(force, torque, weight=self._weight, **self.frames(q))
        return FTReading(time, ft, tt, fw, tw)

    # -- rate -----------------------------------------------------------------------------------
    def sample(self, obs: Observation) -> FTReading | None:
        """A reading if ``obs.time`` has reached the next sample time, else None.

        The first call (after construction or :meth:`reset`) samples; later samples fall on the grid
        ``t0 + k / rate_hz`` anchored at that first time (slots the observations skipped are dropped).

        Raises:
            ExcavsimError: as :meth:`reading`, or time went backwards past the last sample (call
                :meth:`reset` at the start of an episode).
        """
        time = _checked(obs, len(self._qadr))[0]
        if self._t0 is None:
            self._t0, self._k, self._last = time, 0, time
            return self.reading(obs)
        if time < self._last:
            raise UsageError(f"F/T sample time went backwards ({time:.6f} s < last sample {self._last:.6f} s); "
                             f"call ForceSensor.reset() when a new episode starts")
        # Slot index with a small tolerance so that accumulated float time (n * timestep) lands on it.
        k = math.floor((time - self._t0) * self.rate_hz + 1e-6)
        if k <= self._k:
            return None
        self._k, self._last = k, time
        return self.reading(obs)

    def reset(self) -> None:
        """Forget the sampling schedule: the next :meth:`sample` call samples."""
        self._t0: float | None = None
        self._k = 0
        self._last = -math.inf


def _checked(obs: Observation, n_joints: int) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
    """The observation's time, joint angles, F/T force and torque, validated."""
    try:
        time = float(obs.time)
        arrays = [np.asarray(getattr(obs, name), dtype=float) for name in ("q", "ft_force", "ft_torque")]
    except (AttributeError, TypeError, ValueError) as e:
        raise UsageError(f"ForceSensor needs an Observation with time, q, ft_force and ft_torque; "
                         f"got {type(obs).__name__} ({e})") from e
    for name, a, shape in zip(("q", "ft_force", "ft_torque"), arrays, ((n_joints,), (3,), (3,))):
        if a.shape != shape:
            raise UsageError(f"observation {name} must have shape {shape}, got {a.shape}")
        if not np.all(np.isfinite(a)):
            raise WorldError(f"observation {name} must be finite, got {a!r}")
    if not math.isfinite(time):
        raise WorldError(f"observation time must be finite, got {time!r}")
    return time, arrays[0], arrays[1], arrays[2]
