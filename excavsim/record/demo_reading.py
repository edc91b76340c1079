"""Reading an executed dig back from a Rerun recording (``.rrd``), to make a demonstration of it.

:func:`read_dig` returns the raw signals of one dig of a recording written by
:class:`~excavsim.record.trench.TrenchRecorder` (entity tree in that module's docstring): the joint
angles ``joint_deg/<actuator>`` (sampled at the recorder's ``rate_hz``), the executor's F/T readings in
the tip frame ``ft/tip/{x,y,z}`` and the measured cut path ``world/exec/path`` with the time it was
logged (the dig's end). The joint and F/T series come from
:func:`excavsim.record.reading.read_recording` (the recording reader ``excavsim calibrate`` uses); only the
cut paths are read here. Turning them into a
:class:`~excavsim.execution.demonstration.Demonstration` needs the robot's model of itself and is
:func:`excavsim.execution.demonstration.demonstration_from_joints`'s job (``record`` and ``execution`` do not
import each other). Read with Rerun 0.41's ``rerun.chunk.RrdReader``.
"""

from __future__ import annotations

import dataclasses
import pathlib

import numpy as np
import pyarrow as pa
from rerun.chunk import RrdReader

from excavsim.errors import ConfigError, DataFileError, shorten
from excavsim.record.reading import read_recording


@dataclasses.dataclass(frozen=True)
class RecordedDig:
    """One dig's signals from a recording.

    Attributes:
        dig: the dig's number in the episode (1-based).
        joint_times: (N,) [s] sim time of the joint samples between the previous dig's end and this one's.
        joints: (N, 6) joint angles [rad] in :data:`excavsim.constants.ACTUATORS` order.
        ft_times: (M,) [s]; ft_tip: (M, 3) the executor's F/T readings in the tip frame [N].
        path_world: (P, 3) the measured tip path of the cut in world coordinates [m].
        end_time: [s] when the dig ended (the cut path was logged).
    """

    dig: int
    joint_times: np.ndarray
    joints: np.ndarray
    ft_times: np.ndarray
    ft_tip: np.ndarray
    path_world: np.ndarray
    end_time: float


def _seconds(column: pa.Array) -> np.ndarray:
    return np.asarray(column.cast(pa.int64()).to_numpy(zero_copy_only=False), dtype=float) * 1e-9


def cut_paths(path: str | pathlib.Path) -> list[tuple[float, np.ndarray]]:
    """Every executed dig's measured cut path ``world/exec/path`` as (time logged [s], (P, 3) world points [m]),
    in time order (the Clear logged when the next dig is planned is skipped)."""
    try:
        return _cut_paths(path)
    except Exception as exc:  # the reader's error types are not public; pyarrow's and numpy's for odd shapes
        raise DataFileError(f"{path}: not a readable Rerun recording ({type(exc).__name__}: "
                            f"{shorten(exc)})") from None


def _cut_paths(path: str | pathlib.Path) -> list[tuple[float, np.ndarray]]:
    paths = []
    for ch in RrdReader(path).stream().filter(content="/world/exec/path").to_chunks():
        if ch.is_static or "sim_time" not in ch.timeline_names:
            continue
        batch = ch.to_record_batch()
        if "LineStrips3D:strips" not in batch.schema.names:
            continue
        for t, strips in zip(_seconds(batch.column("sim_time")), batch.column("LineStrips3D:strips").to_pylist()):
            if strips:
                points = np.asarray(strips[0], dtype=float)
                if points.ndim != 2 or points.shape[1] != 3 or len(points) < 2:
                    raise ValueError(f"a cut path of shape {points.shape}; allowed: (P >= 2, 3) world points")
                paths.append((float(t), points))
    return sorted(paths, key=lambda x: x[0])


def read_dig(path: str | pathlib.Path, dig: int = 1) -> RecordedDig:
    """Dig number ``dig`` (1-based) of the recording at ``path``.

    Raises:
        DataFileError: the file is missing or not a recording, or it has no joint or F/T series (not
            written by excavsim's recorder).
        ConfigError: it has fewer than ``dig`` digs (naming how many it has).
    """
    p = pathlib.Path(path)
    if not p.is_file():
        raise DataFileError(f"no recording at {p}: give an .rrd file written by `excavsim trench --record FILE.rrd`")
    series = read_recording(p)
    paths = cut_paths(p)
    if not paths:
        raise DataFileError(f"{p}: the recording has no executed dig (no world/exec/path): record an episode with "
                            f"`excavsim trench --record FILE.rrd`")
    if not 1 <= dig <= len(paths):
        raise ConfigError(f"{p}: dig {dig} asked for, the recording has {len(paths)} executed digs "
                          f"(world/exec/path); allowed: 1..{len(paths)}")
    start = paths[dig - 2][0] if dig > 1 else -np.inf
    end, path_world = paths[dig - 1]
    jt, ft_t = series["joint_time"], series["ft_time"]
    jk, fk = (jt > start) & (jt <= end), (ft_t > start) & (ft_t <= end)
    if jk.sum() < 2 or fk.sum() < 2:
        raise DataFileError(f"{p}: dig {dig} has fewer than two joint or F/T samples (joint_deg/*, ft/tip/*)")
    return RecordedDig(dig, jt[jk], np.radians(series["joint_deg"][jk]), ft_t[fk], series["ft_tip"][fk],
                       path_world, end)
