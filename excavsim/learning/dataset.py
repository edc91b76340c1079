"""Force data sets from execution records (Singh 1995 §5.2.2, §5.2.4).

One row per F/T sample taken while the bucket digs (from the dig step's start to the lift-out, and
never after a stall, when the bucket backs out): the dig it came from, the sample time, the features of
:mod:`excavsim.learning.encoding` (action, progress, tip pose, swept volume, terrain before the
dig) and the measured force ``fx``, ``fz`` [N] in the tip frame (x along the blade from heel to
cutting edge, z the blade normal into the bucket; the soil's and the carried load's force on the
bucket, as the wrist sensor reports it, :mod:`excavsim.sensing.ft`).

The tip pose of a sample comes from the joint angles at its time (the robot's encoders, through
its own kinematics), its progress from the nearest point of the planned path, and its swept
volume from the tip's path so far over the mapped surface before the dig (as the planner's volume
constraint counts it). A :class:`ForceDataset` is a table of such rows, saved as Parquet (through
pyarrow, which rerun-sdk already requires), CSV or ``.npz``.

The builder that runs digs in the simulator is :mod:`excavsim.studies.learning.collect`; this module is numpy
only.
"""

from __future__ import annotations

import dataclasses
import json
import math
import pathlib
from collections.abc import Iterable

import numpy as np

from excavsim.errors import DataFileError, DependencyError, UsageError, shorten
from excavsim.handoff.forces import trajectory_progress
from excavsim.learning.encoding import FEATURE_COLUMNS, Samples, Terrain, encode

TARGET_COLUMNS = ("fx", "fz")
ID_COLUMNS = ("dig", "t")
COLUMNS = ID_COLUMNS + FEATURE_COLUMNS + TARGET_COLUMNS
FORMATS = (".parquet", ".csv", ".npz")
PITCH_RADIUS_M = 0.5  # a pitch difference counts as this radius times the angle when matching the path


@dataclasses.dataclass
class ForceDataset:
    """A table of force samples: ``COLUMNS`` -> (n,) float arrays, plus free-form string metadata.

    ``dig`` numbers the digs the rows came from (0, 1, ...), ``t`` is the simulated time [s].
    """

    columns: dict[str, np.ndarray]
    meta: dict[str, str] = dataclasses.field(default_factory=dict)

    def __post_init__(self):
        missing = [c for c in COLUMNS if c not in self.columns]
        if missing:
            raise UsageError(f"a force data set needs the columns {list(COLUMNS)}; missing {missing}")
        self.columns = {c: np.asarray(self.columns[c], dtype=float).reshape(-1) for c in COLUMNS}
        sizes = {v.size for v in self.columns.values()}
        if len(sizes) > 1:
            raise UsageError(f"every column of a force data set must have one length; given {sorted(sizes)}")

    @classmethod
    def empty(cls) -> ForceDataset:
        return cls({c: np.zeros(0) for c in COLUMNS})

    def __len__(self) -> int:
        return int(self.columns["t"].size)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    @property
    def samples(self) -> Samples:
        """The feature columns (what a predictor reads)."""
        return {c: self.columns[c] for c in FEATURE_COLUMNS}

    @property
    def forces(self) -> np.ndarray:
        """(n, 2) measured ``(fx, fz)`` in the tip frame [N]."""
        return np.stack([self.columns["fx"], self.columns["fz"]], axis=-1)

    @property
    def n_digs(self) -> int:
        return int(np.unique(self.columns["dig"]).size)

    def subset(self, index) -> ForceDataset:
        """The rows ``index`` (a boolean mask or integer indices)."""
        return ForceDataset({c: v[index] for c, v in self.columns.items()}, dict(self.meta))

    @classmethod
    def concat(cls, parts: Iterable[ForceDataset], meta: dict[str, str] | None = None) -> ForceDataset:
        """The rows of ``parts`` in order (their metadata is dropped unless given)."""
        parts = list(parts)
        if not parts:
            return cls(cls.empty().columns, dict(meta or {}))
        return cls({c: np.concatenate([p.columns[c] for p in parts]) for c in COLUMNS}, dict(meta or {}))

    # -- files ------------------------------------------------------------------------------------
    def save(self, path: str | pathlib.Path) -> pathlib.Path:
        """Write the table to ``path``: ``.parquet``, ``.csv`` or ``.npz`` by its suffix.

        Raises:
            ExcavsimError: another suffix, or Parquet without pyarrow.
        """
        path = pathlib.Path(path)
        fmt = _format(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        if fmt == ".parquet":
            pa, pq = _pyarrow(path)
            table = pa.table({c: self.columns[c] for c in COLUMNS})
            table = table.replace_schema_metadata({b"excavsim": json.dumps(self.meta).encode()})
            pq.write_table(table, path)
        elif fmt == ".npz":
            np.savez_compressed(path, meta=json.dumps(self.meta), **self.columns)
        else:
            header = "# excavsim " + json.dumps(self.meta) + "\n" + ",".join(COLUMNS)
            np.savetxt(path, np.stack([self.columns[c] for c in COLUMNS], axis=-1), delimiter=",", header=header,
                       comments="", fmt="%.9g")
        return path

    @classmethod
    def load(cls, path: str | pathlib.Path) -> ForceDataset:
        """Read a table written by :meth:`save` (a CSV may also start at its header line, without the
        metadata comment).

        Raises:
            DataFileError: the file is missing, has another suffix, cannot be parsed, or lacks a
                column (the message names the file and the columns missing).
            DependencyError: a Parquet file without pyarrow.
        """
        path = pathlib.Path(path)
        fmt = _format(path)
        if not path.is_file():
            raise DataFileError(f"{path}: no such force data set (build one with `excavsim learn --out DIR`)")
        pq = _pyarrow(path)[1] if fmt == ".parquet" else None
        try:
            columns, meta = _read_table(path, fmt, pq)
        except DataFileError:
            raise
        except Exception as exc:  # numpy's, pyarrow's, zipfile's and json's errors for a garbled file
            raise DataFileError(f"{path}: not a force data set written by excavsim ({type(exc).__name__}: "
                                f"{shorten(exc)})") from None
        if not isinstance(meta, dict):
            raise DataFileError(f"{path}: the metadata is {type(meta).__name__}, not a JSON object")
        missing = [c for c in COLUMNS if c not in columns]
        if missing:
            raise DataFileError(f"{path}: missing the column(s) {', '.join(missing)}; a force data set has "
                                f"{', '.join(COLUMNS)}")
        values = {}
        for c in COLUMNS:
            try:
                v = np.asarray(columns[c], dtype=float)
            except (TypeError, ValueError):
                raise DataFileError(f"{path}: column {c} is not numbers") from None
            if v.ndim != 1:
                raise DataFileError(f"{path}: column {c} has shape {v.shape}; allowed: one value per row")
            values[c] = v
        sizes = sorted({v.size for v in values.values()})
        if len(sizes) > 1:
            raise DataFileError(f"{path}: the columns have different lengths {sizes}; allowed: one length")
        return cls(values, {str(k): v for k, v in meta.items()})


def _read_table(path: pathlib.Path, fmt: str, pq) -> tuple[dict, object]:
    """The raw columns and metadata of a force data set file (checked by :meth:`ForceDataset.load`)."""
    if fmt == ".parquet":
        table = pq.read_table(path)
        raw = (table.schema.metadata or {}).get(b"excavsim", b"{}")
        return {c: table.column(c).to_numpy() for c in table.column_names}, json.loads(raw)
    if fmt == ".npz":
        with np.load(path, allow_pickle=False) as f:
            meta = json.loads(str(f["meta"])) if "meta" in f.files else {}
            return {c: f[c] for c in f.files if c != "meta"}, meta
    with open(path, encoding="utf-8") as fh:
        lines = fh.read().splitlines()
    meta, skip = {}, 0
    if lines and lines[0].startswith("#"):
        if lines[0].startswith("# excavsim "):
            meta = json.loads(lines[0][len("# excavsim "):])
        skip = 1
    if len(lines) <= skip:
        raise DataFileError(f"{path}: no header line (the column names, {', '.join(COLUMNS)})")
    names = [n.strip() for n in lines[skip].split(",")]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise DataFileError(f"{path}: the header names the column(s) {', '.join(twice)} twice")
    body = [ln for ln in lines[skip + 1:] if ln.strip()]
    try:
        data = np.loadtxt(body, delimiter=",", ndmin=2) if body else np.zeros((0, len(names)))
    except ValueError:
        data = None
    if data is None or data.shape[1] != len(names):  # find the line at fault, for the message
        for number, line in enumerate(lines[skip + 1:], start=skip + 2):
            values = line.split(",")
            if line.strip() and len(values) != len(names):
                raise DataFileError(f"{path}: line {number} has {len(values)} values under a header of "
                                    f"{len(names)} columns")
            try:
                [float(v) for v in values if line.strip()]
            except ValueError:
                raise DataFileError(f"{path}: line {number} holds a value that is not a number") from None
        raise DataFileError(f"{path}: the rows are not {len(names)} numbers each")
    return {c: data[:, i] for i, c in enumerate(names)}, meta


def _format(path: pathlib.Path) -> str:
    if path.suffix not in FORMATS:
        raise DataFileError(f"{path}: a force data set is saved as one of {', '.join(FORMATS)}; given {path.suffix!r}")
    return path.suffix


def _pyarrow(path: pathlib.Path):
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        raise DependencyError(f"{path}: Parquet needs pyarrow (pip install pyarrow), or save as .csv or .npz") from None
    return pa, pq


def dig_window(record) -> tuple[float, float]:
    """Simulated times [s] during which the F/T samples of a record belong to the dig.

    From the dig step's start (touch-down found the surface) to the lift-out, cut at a stall.
    """
    lo = record.phase_starts.get("dig", math.inf)
    hi = record.phase_starts.get("lift out", math.inf)
    if record.stall:
        hi = min(hi, float(record.stall["time"]))
    return lo, hi


def samples_from_record(record, *, trace_times: np.ndarray, trace_poses: np.ndarray, terrain: Terrain,
                        phases: np.ndarray, epsilon: float, width: float, dig: int = 0) -> ForceDataset:
    """The rows of one executed dig.

    Args:
        record: the :class:`~excavsim.execution.dig.ExecutionRecord` (``ft``, ``phase_starts``,
            ``stall`` and ``planned_path``, the planned path as shifted by touch-down).
        trace_times: (T,) increasing times of the tip trace [s], covering the dig.
        trace_poses: (T, 3) tip poses (x, z, pitch) at those times, from the joint angles.
        terrain: the scanned terrain before the dig.
        phases: (S,) phases of the planned path (0 penetrate, 1 drag, 2 curl).
        epsilon: the planner's rake offset during penetration [rad] (to read ``alpha`` off the path).
        width: bucket width [m] (swept volume).
        dig: the dig's number in the data set.

    Returns:
        A data set, empty when the dig never started (no contact) or has no samples.
    """
    lo, hi = dig_window(record)
    path = None if record.planned_path is None else np.asarray(record.planned_path, dtype=float)
    times = np.array([t for t, _ in record.ft])
    if path is None or not math.isfinite(lo) or times.size == 0:
        return ForceDataset.empty()
    forces = np.array([f for _, f in record.ft])
    sel = (times >= lo) & (times < hi)
    if not sel.any():
        return ForceDataset.empty()
    times, forces = times[sel], forces[sel]
    trace_times = np.asarray(trace_times, dtype=float)
    trace_poses = np.asarray(trace_poses, dtype=float)
    # the tip at each sample: the trace entry nearest in time
    i = np.clip(np.searchsorted(trace_times, times), 1, len(trace_times) - 1)
    i = np.where(np.abs(trace_times[i - 1] - times) <= np.abs(trace_times[i] - times), i - 1, i)
    tip = trace_poses[i]
    # swept volume along the dense trace from the start of the dig window
    start = int(np.searchsorted(trace_times, lo))
    dense = trace_poses[start:]
    xm = 0.5 * (dense[1:, 0] + dense[:-1, 0])
    zm = 0.5 * (dense[1:, 1] + dense[:-1, 1])
    steps = np.maximum(terrain.elevation(xm) - zm, 0.0) * np.abs(np.diff(dense[:, 0])) * width
    vcum = np.concatenate([[0.0], np.cumsum(steps)])
    volume = vcum[np.clip(i - start, 0, len(vcum) - 1)]
    progress = path_progress(tip, path, np.asarray(phases), epsilon)
    cols = encode(tip, progress, volume, terrain)
    cols.update(dig=np.full(times.size, float(dig)), t=times, fx=forces[:, 0], fz=forces[:, 2])
    return ForceDataset(cols)


def path_progress(tips: np.ndarray, path: np.ndarray, phases: np.ndarray, epsilon: float) -> np.ndarray:
    """``(k, alpha, s1, s2)`` (n, 4) of tip poses (n, 3) at their nearest point of a planned path (S, 3).

    Distances count the pitch at ``PITCH_RADIUS_M`` per radian, so that the curl, which turns the
    bucket where the drag ended, is told from the drag.
    """
    prog = trajectory_progress(path, phases, epsilon)
    if len(path) == 1:
        return np.repeat(prog, len(tips), axis=0)
    scale = np.array([1.0, 1.0, PITCH_RADIUS_M])
    a, b = path[:-1] * scale, path[1:] * scale
    q = np.asarray(tips, dtype=float) * scale
    ab = b - a
    t = np.clip(np.einsum("nsk,sk->ns", q[:, None, :] - a[None], ab) / np.maximum((ab * ab).sum(-1), 1e-12), 0, 1)
    d2 = (((a[None] + t[..., None] * ab[None]) - q[:, None, :]) ** 2).sum(-1)
    s = np.argmin(d2, axis=1)
    tt = t[np.arange(len(s)), s][:, None]
    return prog[s] + tt * (prog[s + 1] - prog[s])
