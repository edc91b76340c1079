"""The recorder base: one episode, of any task, to one Rerun recording; a task's recorder adds its entities.

:class:`EpisodeRecorder` is an :class:`~excavsim.handoff.episode.EpisodeObserver` that owns what every
recording shares, once:

* **the stream**: its own :class:`rerun.RecordingStream` (never the global one, so that several
  episodes recorded in one process stay apart) with a reproducible recording id
  (:func:`recording_id_for`), no wall-clock timeline and no recording properties (they hold the start
  time), written to an ``.rrd`` file with the task's default blueprint before anything is logged,
  and/or streamed live to a viewer over gRPC (``live``, :func:`excavsim.record.live.viewer_url`);
* **the timelines**: ``sim_time`` (duration, simulated seconds) on everything; the samples also carry
  ``step`` (the world's control steps) and the recorder's own sequence timelines
  (:attr:`EpisodeRecorder.sample_timelines`, e.g. trenching's ``dig``);
* **the world's static setup**: ``world`` right-handed with z up, the resolved configuration at
  ``config``, and, when the task asks (:meth:`EpisodeRecorder.draw_bodies`), the machine's bodies:
  their visual geoms static in the body frames, the fixed bodies' poses static, and the moving
  bodies' poses sampled with the signals;
* **the sampling**: after every control step, at ``rate_hz`` of simulated time on a fixed grid, a
  sample of the task's signals (:meth:`EpisodeRecorder.sample`), buffered and sent as columns
  (:meth:`EpisodeRecorder.send`);
* **the end**: on ``finished(result)`` and on ``finished(None)`` (an episode that raised or was
  abandoned) the buffer is sent, the task's end logged (:meth:`EpisodeRecorder.ended`), the stream
  flushed and closed (the file complete, footer included, ``rerun rrd verify`` accepts it), also when
  the task's own logging raises; closing twice does nothing. A recorder records one episode.

A task's recorder subclasses it and overrides the hooks it needs: :meth:`~EpisodeRecorder.begin`
(keep the task's ``started`` arguments, which its ``reset`` returns; return the world),
:meth:`~EpisodeRecorder.config_text`, :meth:`~EpisodeRecorder.blueprint`,
:meth:`~EpisodeRecorder.setup`, :meth:`~EpisodeRecorder.sample`, :meth:`~EpisodeRecorder.send`,
:meth:`~EpisodeRecorder.ended`, and the episode's ``scanned``, ``planned`` and ``dug``. It draws with
the vocabulary of :class:`~excavsim.record.drawing.Drawing` and :mod:`excavsim.record.blueprint`, so it
imports no rerun (the tasks' recorders live in their folders, ``excavsim/tasks/<task>/recording.py``).

Reproducibility: the same episode (seed and configuration) recorded to files of the same name gets the
same recording id and, decoded, the same rows on every entity but wall-clock ones. The files are not
byte-identical: Rerun 0.41 stamps every row and chunk with an id made of the wall time and a random
number, and has no way to set them.
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
import pathlib
import uuid
from collections.abc import Mapping
from typing import Any

import mujoco
import numpy as np
import rerun as rr

from excavsim.errors import ConfigError, UsageError
from excavsim.handoff.episode import EpisodeObserver
from excavsim.record.drawing import Drawing, Times
from excavsim.record.geometry import geom_archetype

BUFFERED_SAMPLES = 512  # samples kept before they are sent as columns


def recording_id_for(name: str, seed: int, config_text: str) -> str:
    """The Rerun recording id of an episode recorded to a file called ``name``: a UUID derived from the
    file's name, the episode's ``seed`` and its resolved configuration (``config_text``), so that the
    same episode recorded again gets the same id, and two different ones never merge in one viewer."""
    digest = hashlib.sha256(config_text.encode()).hexdigest()
    return str(uuid.uuid5(uuid.NAMESPACE_URL, f"excavsim:{name}:seed {seed}:{digest}"))


@dataclasses.dataclass
class Batch:
    """Samples to send: their times (``at``) and each signal's values by name, one per sample."""

    at: Times
    values: dict[str, list]

    def __getitem__(self, name: str) -> np.ndarray:
        """The signal ``name`` as one array, its first axis the samples."""
        return np.asarray(self.values[name])

    def rows(self, name: str) -> list:
        """The signal ``name`` as it was sampled, one entry per sample (for ragged values)."""
        return self.values[name]


class EpisodeRecorder(Drawing, EpisodeObserver):
    """Records one episode to ``path`` (see the module docstring).

    Args:
        path: the ``.rrd`` file to write (parent folders are created; an existing file is replaced).
            None: no file (``live`` only).
        rate_hz: how often the samples are taken [Hz of simulated time].
        recording_id: Rerun's recording id (default: :func:`recording_id_for` the file's name, the
            episode's seed and its configuration).
        live: also stream the episode, as it runs, to the viewer at this gRPC URL
            (``rerun+http://HOST:PORT/proxy``).
        seed: the episode's seed for the recording id (default: the world's ``seed``, else 0).

    Raises:
        ExcavsimError: not an ``.rrd`` path, neither ``path`` nor ``live``, a rate that is not positive;
            :meth:`started` a second time; :meth:`stepped` before :meth:`started`.
    """

    #: the sequence timelines (besides ``step``) every sample carries, their values from :attr:`sequence`
    sample_timelines: tuple[str, ...] = ()

    def __init__(self, path: str | os.PathLike | None, *, rate_hz: float = 10.0, recording_id: str | None = None,
                 live: str | None = None, seed: int | None = None):
        name = type(self).__name__
        if path is None and not live:
            raise UsageError(f"{name} needs a file to write (path) or a viewer to stream to (live)")
        if path is not None and pathlib.Path(path).suffix != ".rrd":
            raise ConfigError(f"{name} writes a Rerun recording, an .rrd file; given {str(path)!r}")
        if not (np.isfinite(rate_hz) and rate_hz > 0):
            raise ConfigError(f"{name} rate_hz must be a positive number [Hz]; given {rate_hz!r}")
        self.path = pathlib.Path(path) if path is not None else None
        self.live = live
        self.rate_hz = float(rate_hz)
        self.recording_id = recording_id  # None: derived when the episode starts
        self.seed = seed
        self.rec: rr.RecordingStream | None = None
        self.world = None
        self.sequence: dict[str, int] = {name: 0 for name in self.sample_timelines}
        self._closed = False
        self._buffer: list[tuple[float, dict, dict]] = []
        self._next_t = 0.0
        self._fixed_meshes: set[str] = set()
        self._moving = np.zeros(0, dtype=int)  # the moving bodies (draw_bodies) and their entities
        self._body_entities: list[str] = []

    # -- the episode's hooks (the lifecycle) -----------------------------------------------------------
    def started(self, *args) -> None:
        """Open the stream with the task's ``started`` arguments, log the static setup (:meth:`setup`)."""
        if self.rec is not None:
            raise UsageError(f"a {type(self).__name__} records one episode; make a new one for "
                             f"{self.path or self.live}")
        self.world = self.begin(*args)
        config = self.config_text()
        name = self.path.name if self.path is not None else "live.rrd"
        seed = self.seed if self.seed is not None else int(getattr(self.world, "seed", 0) or 0)
        self.recording_id = self.recording_id or recording_id_for(name, seed, config)
        rec = rr.RecordingStream("excavsim", recording_id=self.recording_id, send_properties=False)
        rec.set_log_time_enabled(False)  # reproducible files: only the episode's own timelines
        rec.set_log_tick_enabled(False)
        sinks = []
        if self.path is not None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            sinks.append(rr.FileSink(str(self.path)))
        if self.live:
            sinks.append(rr.GrpcSink(self.live))
        rec.set_sinks(*sinks, default_blueprint=self.blueprint())
        rec.send_recording_name(pathlib.Path(name).stem)
        self.rec = rec
        try:
            self._next_t = float(getattr(self.world, "time", 0.0))
            self.frame("world")
            if config:
                self.document("config", config, static=True)
            self.setup()
        except BaseException:
            self.close()  # what was logged stays a valid recording
            raise

    def stepped(self, world) -> None:
        """After a control step: a sample when ``rate_hz`` says so (on a fixed grid of simulated time)."""
        self.require_started("stepped")
        if not self._closed and float(world.time) + 1e-9 >= self._next_t:
            self.take_sample(world)

    def finished(self, result=None) -> None:
        """The episode's end (``result`` None: it raised or was abandoned): the buffered samples, the
        task's end (:meth:`ended`), then the stream closed, whatever the task's logging did."""
        if self.rec is None or self._closed:
            return
        try:
            self.flush()
            self.ended(result)
        finally:
            self.close()

    def close(self) -> None:
        """Flush and close the stream: the file is complete (footer included). Closing twice does nothing."""
        if self.rec is None or self._closed:
            return
        self._closed = True
        self.rec.flush()
        self.rec.disconnect()  # closes the file and writes its footer

    # -- what a task's recorder overrides --------------------------------------------------------------
    def begin(self, *args) -> Any:
        """Keep the task's ``started`` arguments; return the world (something with ``time``, ``seed``), or None."""
        return args[0] if args else None

    def config_text(self) -> str:
        """The run's resolved configuration (markdown), logged at ``config`` and part of the recording id."""
        return ""

    def blueprint(self):
        """The layout the recording opens with (:mod:`excavsim.record.blueprint`), or None: the viewer's."""
        return None

    def setup(self) -> None:
        """Log the static scene and the start (the stream is open, ``world`` set up)."""

    def sample(self, world) -> dict[str, Any]:
        """One sample of the task's signals by name (any values; :meth:`send` gets them as a :class:`Batch`)."""
        return {}

    def send(self, batch: Batch) -> None:
        """Send the buffered samples (as columns, at ``batch.at``); the bodies' poses are sent already."""

    def ended(self, result) -> None:
        """Log the episode's end (``result`` None: it raised or was abandoned)."""

    # -- for the task's recorder ------------------------------------------------------------------------
    def require_started(self, hook: str) -> None:
        """Refuse the episode's ``hook`` before :meth:`started` (a UsageError naming the hook)."""
        if self.rec is None:
            raise UsageError(f"{type(self).__name__}.{hook} before started")

    def take_sample(self, world) -> None:
        """Sample ``world`` now (the moving bodies' poses and :meth:`sample`), and move the next sample's
        time on by whole periods."""
        t = float(world.time)
        self._next_t += max(1, int((t - self._next_t) * self.rate_hz) + 1) / self.rate_hz
        sequences = {"step": int(world.steps)} if hasattr(world, "steps") else {}
        sequences.update((name, self.sequence[name]) for name in self.sample_timelines)
        values = self.sample(world)
        if len(self._moving):
            values["body_xpos"], values["body_xquat"] = world.data.xpos[self._moving], world.data.xquat[self._moving]
        self._buffer.append((t, sequences, {k: np.array(v, copy=True) if isinstance(v, np.ndarray) else v
                                            for k, v in values.items()}))
        if len(self._buffer) >= BUFFERED_SAMPLES:
            self.flush()

    def flush(self) -> None:
        """Send the buffered samples: the bodies' poses, then :meth:`send`."""
        if not self._buffer or self.rec is None or self._closed:
            return
        rows, self._buffer = self._buffer, []
        at = Times(np.array([r[0] for r in rows]), {k: np.array([r[1][k] for r in rows]) for k in rows[0][1]})
        batch = Batch(at, {k: [r[2][k] for r in rows] for k in rows[0][2]})
        if len(self._moving):
            xpos, xquat = batch["body_xpos"], batch["body_xquat"]
            for i, entity in enumerate(self._body_entities):
                self.pose_columns(entity, xpos[:, i], xquat[:, i], at)
        self.send(batch)

    def draw_bodies(self, world, machine: str, places: Mapping[str, str] | None = None) -> None:
        """The machine's bodies in the world (static): each body's visual geoms in its frame at
        ``world/<machine>/<body>/<geom>`` (or at ``places[body name]``, e.g. the soil box's walls at
        ``world/box``), the fixed bodies' poses; the moving bodies' poses are sampled from now on.

        The world's own body, collision geoms (group 3) and the soil's heightfield (logged as terrain)
        are left out.
        """
        m, d = world.model, world.data
        special = {m.body(name).id: entity for name, entity in (places or {}).items()}

        def root(b: int) -> str:
            return special.get(b, f"world/{machine}/{m.body(b).name or f'body_{b}'}")

        for g in range(m.ngeom):
            b = int(m.geom_bodyid[g])
            if b == 0 or m.geom_group[g] == 3 or m.geom_type[g] == mujoco.mjtGeom.mjGEOM_HFIELD:
                continue
            archetype = geom_archetype(m, g)
            if archetype is not None:
                self.rec.log(f"{root(b)}/{m.geom(g).name or f'geom_{g}'}", archetype, static=True)
        moving = [b for b in range(1, m.nbody) if m.body_weldid[b] != 0 and b not in special]
        for b in range(1, m.nbody):
            if b not in moving:
                self.pose(root(b), d.xpos[b], d.xquat[b], static=True)
        self._moving = np.array(moving, dtype=int)
        self._body_entities = [root(b) for b in moving]

