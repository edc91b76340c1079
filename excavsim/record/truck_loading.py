"""Rerun recording of a truck-loading episode with the 25 t excavator (``task: truck_loading``, Rowe 1997 §4, §6).

``excavsim run configs/specs/excavator_truck.yaml --record FILE.rrd``. :class:`TruckLoadingRecorder` is the
episode's observer (``started(world, cfg)``, ``stepped(world)`` after every control step, ``scanned``,
``planned``, ``dug(index, pass)``, ``finished(result)``): the machine and the pit as
:class:`~excavsim.record.excavator.ExcavatorRecorder` records them, plus the truck, its bed's fill and the
per-pass metrics. Everything is the world's truth (the recording shows what happened, not what the mind
believed), except ``world/truck/scan``, the bed as the mind's scanner mapped it.

Timelines ``sim_time`` (duration) and ``pass`` (sequence, 1-based). Entity tree::

    world                          ViewCoordinates (right-handed, z up), static
      <machine>/<body>             Transform3D of each moving body at rate_hz (ExcavatorRecorder's)
      <machine>/<body>/<geom>      the machine's visual geoms, static
      <machine>/cylinders          LineStrips3D: the cylinders pin to pin, at rate_hz
      pit/<geom>                   the ground slabs around the pit, static
      soil/truth                   Mesh3D of the pit's true heightfield: at the start, after each pass, at the end
      truck/truck_<part>           the truck's collision body (chassis, floor, sides, tailgate, headboard,
                                   cab) as boxes, static
      truck                        Transform3D: the truck's frame (the bed's centre on the ground, x along the
                                   truck, y across), static
      truck/fill                   Mesh3D of the bed's fill (truth) in the truck's frame: one vertex per fill
                                   cell at the fill's surface; at the start, after each pass, after a full
                                   truck left, at the end
      truck/scan                   Points3D: the bed scanner's map (the mind's), in the truck's frame, at
                                   each look
    joint_deg/<function>, cylinder_kn/<function>, soil/bucket_l, soil/force_n   ExcavatorRecorder's, at rate_hz
    soil/truck_l                   soil in the truck's bed [l] (truth), at rate_hz
    pass/bucket_l                  soil in the bucket after the dig [l], per pass
    pass/truck_l                   soil in the truck after the pass [l] (the truck being loaded), per pass
    pass/spill_l                   what left the bucket and missed the bed [l], per pass
    pass/cycle_s                   the bucket loading cycle [s] (to the dig + dig + swing-dump-return), per pass
    pass/script_s                  the swing-dump-return script [s] (§6.2's time), per pass
    pass/cost                      §6.2's cost of the pass, per pass
                                   (the pass/ series on the pass timeline and at the pass's end on sim_time)
    log                            TextLog: each pass's line, each truck leaving, the episode's end
"""

from __future__ import annotations

import math
import os

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from excavsim.errors import UsageError
from excavsim.record.excavator import ExcavatorRecorder
from excavsim.record.geometry import MAP_RGB, grid_normals, grid_triangles

FILL_RGB = np.array([205, 150, 80], np.uint8)  # the bed's fill, a warmer sand than the pit's
PASS_SERIES = {  # entity: (series name with its unit, colour)
    "pass/bucket_l": ("soil in the bucket [l]", (245, 160, 40)),
    "pass/truck_l": ("soil in the truck [l]", (150, 100, 210)),
    "pass/spill_l": ("spillage [l]", (220, 40, 30)),
    "pass/cycle_s": ("time per bucket [s]", (80, 140, 250)),
    "pass/script_s": ("swing-dump-return [s]", (44, 160, 44)),
    "pass/cost": ("cost (§6.2)", (250, 250, 250)),
}


def truck_loading_blueprint(machine: str, truck_xy: tuple[float, float] = (0.0, 7.6),
                            dig_xy: tuple[float, float] = (8.0, 2.0)) -> rrb.Blueprint:
    """The layout a truck-loading recording opens with: the site in 3D (the camera on the machine, the dig
    and the truck, whose centres in the world are ``truck_xy`` and ``dig_xy`` [m], rather than on the whole
    ground), the per-pass metrics, the signals."""
    target = np.array([(truck_xy[0] + dig_xy[0]) / 3.0, (truck_xy[1] + dig_xy[1]) / 3.0, 1.0])
    away = np.array([-0.9, -1.0, 0.0]) * 2.0 * max(math.hypot(*truck_xy), math.hypot(*dig_xy))
    eye = rrb.EyeControls3D(kind=rrb.Eye3DKind.Orbital, position=target + away + [0.0, 0.0, 13.0],
                            look_target=target, eye_up=(0, 0, 1))

    whole = rrb.TimeRange(start=rrb.TimeRangeBoundary.infinite(), end=rrb.TimeRangeBoundary.infinite())

    def series(name: str, contents: list[str], every_pass: bool = False) -> rrb.TimeSeriesView:
        return rrb.TimeSeriesView(name=name, origin="/", contents=contents,
                                  axis_x=rrb.TimeAxis(view_range=whole) if every_pass else None,
                                  plot_legend=rrb.PlotLegend(rrb.Corner2D.RightTop, visible=True))

    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Vertical(rrb.Spatial3DView(name=f"{machine} loading the truck", origin="/world",
                                               eye_controls=eye),
                         rrb.TextLogView(name="log", origin="/log"), row_shares=[4, 1]),
            rrb.Vertical(rrb.Tabs(series("soil per pass [l]", ["+ /pass/bucket_l", "+ /pass/truck_l",
                                                               "+ /pass/spill_l"], every_pass=True),
                                  series("time per pass [s]", ["+ /pass/cycle_s", "+ /pass/script_s"], every_pass=True),
                                  series("cost per pass", ["+ /pass/cost"], every_pass=True)),
                         series("soil [l]", ["+ /soil/bucket_l", "+ /soil/truck_l"]),
                         rrb.Tabs(series("joints [deg]", ["+ /joint_deg/**"]),
                                  series("cylinders [kN]", ["+ /cylinder_kn/**"]))),
            column_shares=[3, 2]),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(timeline="sim_time", state="collapsed"),
    )


class TruckLoadingRecorder(ExcavatorRecorder):
    """Records one truck-loading episode to ``path`` (see the module docstring).

    Args:
        path: the ``.rrd`` file to write (parent folders are created; an existing file is replaced).
        rate_hz: how often the machine's pose and the signals are sampled [Hz of simulated time].

    Raises:
        ExcavsimError: not an ``.rrd`` path or a rate that is not positive.
    """

    def __init__(self, path: str | os.PathLike, *, rate_hz: float = 10.0):
        # the pit's terrain is logged per pass (dug), not on a period: a period longer than any episode
        super().__init__(path, rate_hz=rate_hz, soil_period_s=1e12)
        self.cfg = None
        self.world = None
        self._bed_m3: float | None = None  # the bed's volume at the last step [m^3] (a drop: a truck left)

    # -- the episode's hooks ------------------------------------------------------------------------------------
    def started(self, world, cfg=None) -> None:
        """Open the file, log the machine, the pit, the truck and the empty bed."""
        self.cfg, self.world = cfg, world
        super().started(world)
        rec = self.rec
        for f, (name, colour) in PASS_SERIES.items():  # points: one value a pass, at the pass's end on sim_time
            rec.log(f, rr.SeriesPoints(names=name, colors=colour, marker_sizes=4.0), static=True)
        rec.log("soil/truck_l", rr.SeriesLines(names="soil in the truck [l]", colors=(150, 100, 210)), static=True)
        self._fill(world, float(world.data.time))

    def scanned(self, index, emap, bed_depth=None) -> None:
        """At each look: the bed as the mind's scanner mapped it (the fill's surface, NaN cells left out)."""
        if self.rec is None or bed_depth is None or self.world is None:
            return
        t = self.world.truck
        depth = np.asarray(bed_depth, float)
        nrows, ncols = depth.shape
        cell_u, cell_v = t.length_m / ncols, t.width_m / nrows
        u = -0.5 * t.length_m + (np.arange(ncols) + 0.5) * cell_u
        v = -0.5 * t.width_m + (np.arange(nrows) + 0.5) * cell_v
        uu, vv = np.meshgrid(u, v)
        ok = np.isfinite(depth)  # in the truck's frame, as the fill
        pts = np.stack([uu[ok], vv[ok], t.floor_m + depth[ok]], axis=1).astype(np.float32)
        self._at(float(self.world.data.time))
        self.rec.log("world/truck/scan", rr.Points3D(pts, radii=0.03, colors=MAP_RGB.astype(np.uint8)))

    def planned(self, *args) -> None:
        """Nothing: the pass's choice shows in its line of the log once it is dug."""

    def stepped(self, world) -> None:
        """After a control step: the machine and the signals at ``rate_hz``; the fill when a truck left."""
        if self.rec is None:
            raise UsageError("TruckLoadingRecorder.stepped before started")
        bed_m3 = world.bed.volume()  # it only grows (the bed catches, settling keeps it) until a truck leaves
        if self._bed_m3 is not None and bed_m3 < self._bed_m3 - 1e-9:
            self._fill(world, float(world.data.time))  # the full truck left, an empty one is in its place
        self._bed_m3 = bed_m3
        super().stepped(world)

    def dug(self, index: int, p) -> None:
        """After a pass: the pit's terrain, the bed's fill, the pass's metrics and its line of the log."""
        if self.rec is None:
            raise UsageError("TruckLoadingRecorder.dug before started")
        w, rec = self.world, self.rec
        t = float(w.data.time)
        self._terrain(w, t)
        self._fill(w, t)
        truck_l = 1000.0 * w.bed.volume()
        rec.set_time("pass", sequence=int(index))  # the pass and its end on sim_time
        values = {"pass/bucket_l": 1000.0 * p.bucket_m3, "pass/truck_l": truck_l, "pass/spill_l": 1000.0 * p.spill_m3,
                  "pass/cycle_s": p.cycle_s, "pass/script_s": p.script_s, "pass/cost": p.cost}
        for entity, value in values.items():
            if math.isfinite(value):
                rec.log(entity, rr.Scalars(float(value)))
        self._at(t)
        rec.log("log", rr.TextLog(f"pass {index} ({p.source}): {p.cycle_s:.1f} s (dig {p.dig_s:.1f} s, "
                                  f"swing-dump-return {p.script_s:.1f} s); bucket {1000 * p.bucket_m3:.0f} l, "
                                  f"into the truck {1000 * p.bed_m3:.0f} l, spilled {1000 * p.spill_m3:.0f} l, "
                                  f"the truck holds {truck_l:.0f} l",
                                  level=rr.TextLogLevel.INFO if p.outcome == "end" else rr.TextLogLevel.WARN))

    def finished(self, result=None) -> None:
        """The last sample, terrain and fill, the episode's end in the log; closes the file (footer included)."""
        if self.rec is None or self.world is None:
            return
        w = self.world
        t = float(w.data.time)
        self._fill(w, t)
        self._at(t)
        if result is not None:
            self.rec.log("log", rr.TextLog(f"{result.end}: {result.reason}"))
        else:
            self.rec.log("log", rr.TextLog("the episode was abandoned", level=rr.TextLogLevel.WARN))
        super().finished(w)

    # -- ExcavatorRecorder's parts --------------------------------------------------------------------------------
    def _config_text(self, world) -> str:
        cfg = self.cfg.model_dump_json() if hasattr(self.cfg, "model_dump_json") else repr(self.cfg)
        return f"machine: {world.spec.name}\ntask: truck_loading\ntruck: {world.truck!r}\nconfig: {cfg}\n"

    def _open(self, rec: rr.RecordingStream) -> None:
        t = self.world.truck
        cfg = getattr(self.cfg, "dig", None)  # the candidate digs' middle, for the camera
        if cfg is not None:
            r, a = float(np.mean(cfg.radii_m)), math.radians(float(np.mean(cfg.swings_deg)))
            dig = (r * math.cos(a), r * math.sin(a))
        else:
            dig = (8.0, 2.0)
        rec.save(str(self.path), default_blueprint=truck_loading_blueprint(self.machine, (t.x_m, t.y_m), dig))

    def _root(self, b: int) -> str:
        if self._names[b] == "truck":
            return "world/truck"
        return super()._root(b)

    def _sample(self, world, t: float) -> None:
        super()._sample(world, t)
        self.rec.log("soil/truck_l", rr.Scalars(1000.0 * world.bed.volume()))

    def _at(self, t: float) -> None:
        """Log on ``sim_time`` = ``t`` alone (no pass index)."""
        self.rec.reset_time()
        self.rec.set_time("sim_time", duration=t)

    def _fill(self, world, t: float) -> None:
        """The bed's fill (truth) as a mesh in the truck's frame (``world/truck``'s: the bed's centre on the
        ground, x along the truck, y across): a vertex at each fill cell's centre, at the fill's surface."""
        bed = world.bed
        u, v = bed.centres_local()
        uu, vv = np.meshgrid(u, v)  # (nrows, ncols): rows across the truck, columns along it
        verts = np.stack([uu, vv, bed.surface_z()], axis=-1).reshape(-1, 3).astype(np.float32)
        self._at(t)
        self.rec.log("world/truck/fill", rr.Mesh3D(vertex_positions=verts,
                                                   triangle_indices=grid_triangles(bed.nrows, bed.ncols),
                                                   vertex_normals=grid_normals(bed.fill, bed.cell),
                                                   albedo_factor=FILL_RGB))
        self._bed_m3 = bed.volume()


__all__ = ["TruckLoadingRecorder", "truck_loading_blueprint"]
