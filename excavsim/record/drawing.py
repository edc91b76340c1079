"""The drawing vocabulary of a recording: what a task's recorder logs, in the words of the episode.

:class:`Drawing` is mixed into :class:`~excavsim.record.base.EpisodeRecorder`; its methods log to
the recorder's own stream (``self.rec``) with Rerun 0.41's archetypes, so that a task's recorder
(``excavsim/tasks/<task>/recording.py``) draws terrain, paths, boxes, points and signals without
importing rerun: only :mod:`excavsim.record` does. Conventions (STYLE's recording section): the world
is right-handed with z up; a terrain's triangles are logged once (static) and then only its vertices;
MuJoCo's ``wxyz`` quaternions become Rerun's ``xyzw`` in :func:`~excavsim.record.geometry.quat_xyzw`
alone; a signal sampled over time is sent as columns (``send_columns``) at :class:`Times`; text goes to
``log`` as a ``TextLog``. Colours are RGB triples (0-255), lengths metres, times simulated seconds.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence

import numpy as np
import rerun as rr

from excavsim.record.geometry import grid_normals, grid_triangles, quat_xyzw

INFO, WARN, ERROR = "INFO", "WARN", "ERROR"  # the levels of a line of the log


@dataclasses.dataclass(frozen=True)
class Times:
    """The times of a column of rows: ``sim_time`` [s] (n,) and sequence timelines by name, each (n,)
    or one number for every row."""

    sim_time: np.ndarray
    sequences: Mapping[str, np.ndarray | int] = dataclasses.field(default_factory=dict)

    def columns(self) -> list[rr.TimeColumn]:
        t = np.asarray(self.sim_time, dtype=float)
        return [rr.TimeColumn("sim_time", duration=t),
                *(rr.TimeColumn(name, sequence=np.broadcast_to(np.asarray(s, dtype=np.int64), t.shape))
                  for name, s in self.sequences.items())]


def _rgb(colours) -> np.ndarray:
    """(1, 3) or (n, 3) uint8 colours from one RGB triple or n of them (Rerun gives one to every instance)."""
    return np.asarray(colours).astype(np.uint8).reshape(-1, 3)


def _vertex_rgb(colours, n: int) -> np.ndarray:
    """(n, 3) uint8 colours of n vertices from one RGB triple or n of them."""
    c = _rgb(colours)
    return np.tile(c, (n, 1)) if len(c) == 1 else c


class Drawing:
    """Logging in the words of an episode (see the module docstring); ``self.rec`` is the open stream."""

    rec: rr.RecordingStream | None
    _fixed_meshes: set[str]  # the entities whose triangles are logged (grid_mesh with fixed)

    # -- time and text --------------------------------------------------------------------------------
    def at(self, sim_time: float | None = None, **sequences: int) -> None:
        """Log what follows at ``sim_time`` [s] and the given sequence timelines only (``dig=3``)."""
        self.rec.reset_time()
        if sim_time is not None:
            self.rec.set_time("sim_time", duration=float(sim_time))
        for name, value in sequences.items():
            self.rec.set_time(name, sequence=int(value))

    def frame(self, entity: str) -> None:
        """``entity`` is a 3-D space, right-handed with z up (static)."""
        self.rec.log(entity, rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)

    def document(self, entity: str, markdown: str, *, static: bool = False) -> None:
        """A markdown document at ``entity`` (a configuration, a summary)."""
        self.rec.log(entity, rr.TextDocument(markdown, media_type=rr.MediaType.MARKDOWN), static=static)

    def say(self, text: str, level: str = INFO) -> None:
        """A line of the text log ``log`` (level :data:`INFO`, :data:`WARN` or :data:`ERROR`)."""
        self.rec.log("log", rr.TextLog(text, level=level))

    def clear(self, entity: str) -> None:
        """Nothing at ``entity`` from now on (until it is logged again)."""
        self.rec.log(entity, rr.Clear(recursive=False))

    # -- signals --------------------------------------------------------------------------------------
    def series_style(self, entity: str, name: str, colour, *, lines: bool = True, points: bool = False,
                     width: float | None = None, marker_size: float | None = None) -> None:
        """How the time series at ``entity`` is drawn (static): its name with its unit, its colour, as a
        line and/or as points."""
        parts = []
        if lines:
            parts.append(rr.SeriesLines(names=name, colors=colour, widths=width))
        if points:
            parts.append(rr.SeriesPoints(names=name, colors=colour, marker_sizes=marker_size))
        self.rec.log(entity, *parts, static=True)

    def scalar(self, entity: str, value: float) -> None:
        """One value of the time series at ``entity``, at the current time."""
        self.rec.log(entity, rr.Scalars(float(value)))

    def scalar_columns(self, entity: str, values, at: Times) -> None:
        """The values (n,) of the time series at ``entity`` at the times ``at``."""
        self.rec.send_columns(entity, indexes=at.columns(),
                              columns=rr.Scalars.columns(scalars=np.asarray(values, dtype=float)))

    # -- poses and shapes -----------------------------------------------------------------------------
    def pose(self, entity: str, translation, quaternion_wxyz, *, static: bool = False) -> None:
        """The frame of ``entity`` (a body) in its parent's: a translation [m] and MuJoCo's quaternion."""
        self.rec.log(entity, rr.Transform3D(translation=translation, quaternion=quat_xyzw(quaternion_wxyz)),
                     static=static)

    def pose_columns(self, entity: str, translations, quaternions_wxyz, at: Times) -> None:
        """The frames (n, 3), (n, 4 wxyz) of ``entity`` at the times ``at`` (re-logs every field)."""
        self.rec.send_columns(entity, indexes=at.columns(), columns=rr.Transform3D.columns(
            translation=np.asarray(translations), quaternion=quat_xyzw(quaternions_wxyz)))

    def lines(self, entity: str, strips: Sequence, *, colours, radii=None, labels=None, show_labels: bool | None = None,
              static: bool = False) -> None:
        """Line strips (each (k, 3) [m]) with a colour each (or one for all), radii [m] and labels."""
        strips = [np.asarray(s, dtype=np.float32) for s in strips]
        self.rec.log(entity, rr.LineStrips3D(strips, colors=_rgb(colours), radii=radii, labels=labels,
                                             show_labels=show_labels), static=static)

    def line_columns(self, entity: str, rows: Sequence[Sequence], *, colour, radius: float, at: Times) -> None:
        """Line strips over time: ``rows[i]``, the strips (each (k, 3) [m]) at the ``i``-th time of ``at``."""
        strips = [np.asarray(s, dtype=np.float32) for row in rows for s in row]
        n = len(strips)
        self.rec.send_columns(entity, indexes=at.columns(), columns=rr.LineStrips3D.columns(
            strips=strips, colors=_vertex_rgb(colour, n), radii=np.full(n, radius, np.float32)).partition(
            [len(row) for row in rows]))

    def points(self, entity: str, positions, *, colours=None, radii=None, labels=None,
               show_labels: bool | None = None, static: bool = False) -> None:
        """Points (n, 3) [m] with colours, radii [m] and labels."""
        positions = np.asarray(positions, dtype=np.float32).reshape(-1, 3)
        colours = None if colours is None else _rgb(colours)
        self.rec.log(entity, rr.Points3D(positions, colors=colours, radii=radii, labels=labels,
                                         show_labels=show_labels), static=static)

    def point_columns(self, entity: str, positions, *, radius: float, at: Times) -> None:
        """One point a time: ``positions`` (n, 3) [m] at the times ``at``."""
        positions = np.asarray(positions, dtype=np.float32)
        self.rec.send_columns(entity, indexes=at.columns(), columns=[
            *rr.Points3D.columns(positions=positions), *rr.Points3D.columns(
                radii=np.full(len(positions), radius, np.float32))])

    def boxes(self, entity: str, centres, half_sizes, *, colours, labels=None, show_labels: bool | None = None,
              solid: bool = False, radii=None) -> None:
        """Axis-aligned boxes (n, 3) [m], filled when ``solid`` (else wireframe of line radius ``radii``)."""
        centres = np.asarray(centres, dtype=np.float32).reshape(-1, 3)
        self.rec.log(entity, rr.Boxes3D(centers=centres, half_sizes=half_sizes, colors=_rgb(colours),
                                        labels=labels, show_labels=show_labels, radii=radii,
                                        fill_mode=rr.components.FillMode.Solid if solid else None))

    # -- terrain --------------------------------------------------------------------------------------
    def grid_mesh(self, entity: str, x: np.ndarray, y: np.ndarray, heights: np.ndarray, cell: float, *,
                  colours, z_offset: float = 0.0, fixed: bool = False) -> None:
        """A height grid as a mesh: a vertex at each (``x[col]``, ``y[row]``, ``heights[row, col]`` +
        ``z_offset``) [m], coloured per vertex (or one colour), normals from the heights on cells of ``cell``.

        With ``fixed`` the grid's triangles are logged once, static, the first time, and every later log
        sends only the vertices (the grid must keep its shape: the world's terrain); without, every log
        is a whole mesh (a scanned map).
        """
        heights = np.asarray(heights, dtype=float)
        xs, ys = np.meshgrid(x, y)
        verts = np.stack([xs, ys, heights + z_offset], axis=-1).reshape(-1, 3).astype(np.float32)
        fields = dict(vertex_positions=verts, vertex_normals=grid_normals(heights, cell),
                      vertex_colors=_vertex_rgb(colours, len(verts)))
        if not fixed:
            self.rec.log(entity, rr.Mesh3D(triangle_indices=grid_triangles(*heights.shape), **fields))
            return
        if entity not in self._fixed_meshes:
            self._fixed_meshes.add(entity)
            self.rec.log(entity, rr.Mesh3D.from_fields(triangle_indices=grid_triangles(*heights.shape)), static=True)
        self.rec.log(entity, rr.Mesh3D.from_fields(**fields))

    def heightfield(self, entity: str, grid, *, colours) -> None:
        """The world's true terrain (a :class:`~excavsim.world.soil.SoilGrid`: heights above its ``z0`` on
        cells from ``x0``, ``y0``) as a fixed mesh (see :meth:`grid_mesh`)."""
        h = grid.heights
        self.grid_mesh(entity, grid.x0 + np.arange(h.shape[1]) * grid.cell, grid.y0 + np.arange(h.shape[0]) * grid.cell,
                       h, grid.cell, colours=colours, z_offset=grid.z0, fixed=True)

    def height_map(self, entity: str, emap, *, colours) -> None:
        """A scanned :class:`~excavsim.handoff.maps.ElevationMap` as a whole mesh at its cells' centres."""
        xc, yc = emap.centres()
        self.grid_mesh(entity, xc, yc, emap.heights, emap.cell, colours=colours)
