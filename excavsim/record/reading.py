"""Reading an episode's Rerun recording back as plain arrays (for ``excavsim calibrate RECORDING.rrd``).

:func:`read_recording` reads, with ``rerun.chunk.RrdReader`` (rerun-sdk 0.41), what
:class:`~excavsim.record.trench.TrenchRecorder` logs that a calibration needs -- the robot's own
measurements, never the truth entities:

* ``ft/tip/{x,y,z}``: the executor's F/T readings in the tip frame [N], at their ``sim_time``;
* ``joint_deg/<actuator>``: the joint angles [deg] at the recorder's rate;
* ``world/soil/scan``: every scanned elevation map (its vertex grid) as an
  :class:`~excavsim.handoff.maps.ElevationMap`, at the time it was logged;
* ``log``: the text log (the plans and digs), and ``config``: the resolved configuration (YAML).
"""

from __future__ import annotations

import os
import re

import numpy as np
import pyarrow as pa
import yaml

from excavsim import constants
from excavsim.errors import DataFileError, shorten
from excavsim.handoff.maps import ElevationMap


def _times(batch) -> np.ndarray:
    return batch.column("sim_time").cast(pa.int64()).to_numpy(zero_copy_only=False) / 1e9


def _scalars(batch) -> np.ndarray:
    return np.array([v[0] if v else np.nan for v in batch.column("Scalars:scalars").to_pylist()], dtype=float)


def _series(parts: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    if not parts:
        return np.zeros(0), np.zeros(0)
    t = np.concatenate([p[0] for p in parts])
    v = np.concatenate([p[1] for p in parts])
    order = np.argsort(t, kind="stable")
    return t[order], v[order]


def _map(positions: np.ndarray, time: float) -> ElevationMap:
    xs = np.unique(np.round(positions[:, 0], 9))
    ys = np.unique(np.round(positions[:, 1], 9))
    if xs.size < 2 or ys.size < 2 or xs.size * ys.size != len(positions):
        raise DataFileError("world/soil/scan is not a grid of vertices (not an excavsim recording)")
    cell = float(np.median(np.diff(xs)))
    heights = positions[:, 2].reshape(ys.size, xs.size)
    return ElevationMap(float(xs[0] - cell / 2), float(ys[0] - cell / 2), cell, heights.astype(float),
                        np.ones(heights.shape, dtype=bool), float(time))


def read_recording(path: str | os.PathLike) -> dict:
    """The F/T, joint, map, log and configuration series of an excavsim recording, as numpy arrays.

    Returns:
        ``ft_time`` (n,) [s] and ``ft_tip`` (n, 3) [N]; ``joint_time`` (m,) [s] and ``joint_deg``
        (m, 6) in the order of ``constants.ACTUATORS``; ``maps``: [(time [s], ElevationMap)] in time
        order; ``log``: [(time [s], text)] in time order; ``config``: the resolved configuration (a
        dict, empty when absent); ``soil`` (from it) and ``seed`` (from the summary) where present.

    Raises:
        DataFileError: the file is missing or not a Rerun recording, or has no F/T samples in the
            tip frame or no joint angles, or holds them malformed (the message names the file).
    """
    if not os.path.isfile(path):
        raise DataFileError(f"{path}: no such recording")
    try:
        return _read(path)
    except DataFileError as exc:
        if str(exc).startswith(f"{path}:"):
            raise
        raise DataFileError(f"{path}: {exc}") from None
    except Exception as exc:  # a recording of other entities' shapes: rerun's, pyarrow's and numpy's errors
        raise DataFileError(f"{path}: not an excavsim recording ({type(exc).__name__}: {shorten(exc)})") from None


def _read(path: str | os.PathLike) -> dict:
    """:func:`read_recording` without its wrapping of errors."""
    from rerun.chunk import RrdReader

    ft: dict[str, list] = {a: [] for a in "xyz"}
    joints: dict[str, list] = {n: [] for n in constants.ACTUATORS}
    maps, log, config = [], [], ""
    found: dict[str, int] = {}
    try:
        chunks = list(RrdReader(path).stream().to_chunks())
    except Exception as exc:  # rerun raises its own error types for a file that is not an .rrd
        raise DataFileError(f"{path}: not a Rerun recording ({exc})") from None
    for chunk in chunks:
        name = chunk.entity_path
        if name == "/config" and chunk.is_static:
            texts = chunk.to_record_batch().column("TextDocument:text").to_pylist()
            config = texts[-1][0] if texts and texts[-1] else config
        if chunk.is_static or "sim_time" not in chunk.timeline_names:
            continue
        if name.startswith("/ft/tip/"):
            b = chunk.to_record_batch()
            ft[name[-1]].append((_times(b), _scalars(b)))
        elif name.startswith("/joint_deg/") and name.split("/")[-1] in joints:
            b = chunk.to_record_batch()
            joints[name.split("/")[-1]].append((_times(b), _scalars(b)))
        elif name == "/world/soil/scan":
            b = chunk.to_record_batch()
            for t, verts in zip(_times(b), b.column("Mesh3D:vertex_positions").to_pylist()):
                if verts:
                    maps.append((float(t), _map(np.asarray(verts, dtype=float).reshape(-1, 3), t)))
        elif name == "/summary" and "seed" not in found:
            texts = chunk.to_record_batch().column("TextDocument:text").to_pylist()
            m = re.search(r"seed (\d+)", texts[0][0] if texts and texts[0] else "")
            if m:
                found["seed"] = int(m.group(1))
        elif name == "/log":
            b = chunk.to_record_batch()
            log += [(float(t), s[0]) for t, s in zip(_times(b), b.column("TextLog:text").to_pylist()) if s]
    series = {a: _series(p) for a, p in ft.items()}
    ft_time = series["x"][0]
    if ft_time.size == 0:
        raise DataFileError(f"{path}: the recording has no F/T samples in the tip frame (ft/tip/x, y, z); "
                            "record an episode with `excavsim trench --record FILE` or `excavsim calibrate "
                            "RECORD.npz --record-digs N --rrd FILE`")
    for a in "yz":
        if not np.array_equal(series[a][0], ft_time):
            raise DataFileError(f"{path}: ft/tip/{a} is not sampled at the times of ft/tip/x")
    jseries = {n: _series(p) for n, p in joints.items()}
    joint_time = jseries[constants.ACTUATORS[0]][0]
    if joint_time.size == 0 or any(not np.array_equal(jseries[n][0], joint_time) for n in constants.ACTUATORS):
        raise DataFileError(f"{path}: the recording has no joint angles (joint_deg/<actuator>) at common times")
    out = {"ft_time": ft_time, "ft_tip": np.stack([series[a][1] for a in "xyz"], axis=-1),
           "joint_time": joint_time, "joint_deg": np.stack([jseries[n][1] for n in constants.ACTUATORS], axis=-1),
           "maps": sorted(maps, key=lambda m: m[0]), "log": sorted(log, key=lambda e: e[0]), "config": {}, **found}
    match = re.search(r"```yaml\n(.*)```", config, re.S)
    if match:
        config = yaml.safe_load(match.group(1)) or {}
        if not isinstance(config, dict):
            raise DataFileError(f"{path}: the recorded configuration is not a mapping")
        out["config"] = config
        scene = config.get("scene") or {}
        out["soil"] = scene.get("soil", "unknown") if isinstance(scene, dict) else "unknown"
    return out
