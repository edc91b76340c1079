"""Named read-outs of the compiled model: one table of the addresses the code reads, and the keyframes.

Every module that reads MuJoCo's arrays by address (the simulation facade, the F/T sensor, the
scanner, the recorder, the loop's tip trace) takes its indices from :class:`ModelIndex`, built once
per model from the names of :mod:`excavsim.constants` (dm_control's ``Physics.named`` does the
same by string at every access, which costs too much per control step). A missing element raises
:class:`~excavsim.errors.ModelError` naming what is available. The ``home`` and ``park`` poses are
the model's keyframes (``models/t3/scene.xml``), never a copy in Python.

Duck-typed on ``mujoco.MjModel`` (``model.joint(name)``, ...), so this module imports no MuJoCo.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from excavsim import constants
from excavsim.errors import ModelError

_KINDS = {  # accessor on MjModel -> its element count
    "joint": "njnt", "actuator": "nu", "body": "nbody", "site": "nsite", "geom": "ngeom", "sensor": "nsensor",
    "key": "nkey", "hfield": "nhfield", "numeric": "nnumeric",
}


def element_id(model, kind: str, name: str) -> int:
    """The id of the ``kind`` element (``joint``, ``site``, ``body``, ...) called ``name``.

    Raises:
        ModelError: no such element; the message lists the ones the model has.
    """
    try:
        return int(getattr(model, kind)(name).id)
    except KeyError:
        names = [getattr(model, kind)(i).name for i in range(getattr(model, _KINDS[kind]))]
        raise ModelError(f"{kind} {name!r} not found in the model. Available: {names}") from None


def keyframe_qpos(model, name: str, joints: tuple[str, ...] = constants.JOINTS) -> np.ndarray:
    """The joint angles of keyframe ``name`` in the order of ``joints`` (default the T3's six,
    :data:`~excavsim.constants.JOINTS`) [rad]."""
    key = element_id(model, "key", name)
    qpos = np.asarray(model.key_qpos[key], dtype=float)
    return qpos[[int(model.jnt_qposadr[element_id(model, "joint", j)]) for j in joints]].copy()


@dataclasses.dataclass(frozen=True)
class ModelIndex:
    """Addresses of the elements the code reads, by name (see :mod:`excavsim.constants`).

    Attributes:
        qpos, dof: (6,) ``qpos`` and ``qvel`` addresses of the joints, in ``constants.JOINTS`` order.
        planar_qpos: (3,) ``qpos`` addresses of shoulder, elbow and wrist pitch.
        actuator: (6,) actuator ids in ``constants.ACTUATORS`` order.
        ft_force, ft_torque: ``sensordata`` addresses of the wrist force and torque sensors.
        bucket_body: the bucket's body id.
        bucket_tip_site, ft_site, scanner_site: site ids.
        home, park: (6,) joint angles of the model's keyframes [rad].
    """

    qpos: np.ndarray
    dof: np.ndarray
    planar_qpos: np.ndarray
    actuator: np.ndarray
    ft_force: int
    ft_torque: int
    bucket_body: int
    bucket_tip_site: int
    ft_site: int
    scanner_site: int
    home: np.ndarray
    park: np.ndarray

    @classmethod
    def from_model(cls, model) -> ModelIndex:
        """Look every name up in ``model`` (a compiled ``mujoco.MjModel``).

        Raises:
            ModelError: an element is missing (the message lists what the model has).
        """
        joints = [element_id(model, "joint", j) for j in constants.JOINTS]
        planar = [element_id(model, "joint", j) for j in constants.PLANAR_JOINTS]
        return cls(
            qpos=np.array([model.jnt_qposadr[j] for j in joints]),
            dof=np.array([model.jnt_dofadr[j] for j in joints]),
            planar_qpos=np.array([model.jnt_qposadr[j] for j in planar]),
            actuator=np.array([element_id(model, "actuator", a) for a in constants.ACTUATORS]),
            ft_force=int(model.sensor_adr[element_id(model, "sensor", constants.FT_FORCE_SENSOR)]),
            ft_torque=int(model.sensor_adr[element_id(model, "sensor", constants.FT_TORQUE_SENSOR)]),
            bucket_body=element_id(model, "body", constants.BUCKET_BODY),
            bucket_tip_site=element_id(model, "site", constants.BUCKET_TIP_SITE),
            ft_site=element_id(model, "site", constants.FT_SITE),
            scanner_site=element_id(model, "site", constants.SCANNER_SITE),
            home=keyframe_qpos(model, "home"),
            park=keyframe_qpos(model, "park"),
        )
