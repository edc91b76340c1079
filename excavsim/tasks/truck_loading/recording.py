"""The Rerun recording of a truck-loading episode with the 25 t excavator (``task: truck_loading``, Rowe 1997 §4, §6).

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
    config                         the machine, the truck and the task's configuration, static
    log                            TextLog: each pass's line, each truck leaving, the episode's end
"""

from __future__ import annotations

import math
import os

import numpy as np

from excavsim import constants
from excavsim.record.blueprint import column, layout, log_view, row, series_view, tabs, world_view
from excavsim.record.drawing import INFO, WARN
from excavsim.record.excavator import ExcavatorRecorder
from excavsim.record.geometry import MAP_RGB
from excavsim.record.base import Batch

FILL_RGB = (205, 150, 80)  # the bed's fill, a warmer sand than the pit's
PASS_SERIES = {  # entity: (series name with its unit, colour)
    "pass/bucket_l": ("soil in the bucket [l]", (245, 160, 40)),
    "pass/truck_l": ("soil in the truck [l]", (150, 100, 210)),
    "pass/spill_l": ("spillage [l]", (220, 40, 30)),
    "pass/cycle_s": ("time per bucket [s]", (80, 140, 250)),
    "pass/script_s": ("swing-dump-return [s]", (44, 160, 44)),
    "pass/cost": ("cost (§6.2)", (250, 250, 250)),
}


def truck_loading_blueprint(machine: str, truck_xy: tuple[float, float] = (0.0, 7.6),
                            dig_xy: tuple[float, float] = (8.0, 2.0)):
    """The layout a truck-loading recording opens with: the site in 3D (the camera on the machine, the dig
    and the truck, whose centres in the world are ``truck_xy`` and ``dig_xy`` [m], rather than on the whole
    ground), the per-pass metrics, the signals."""
    target = np.array([(truck_xy[0] + dig_xy[0]) / 3.0, (truck_xy[1] + dig_xy[1]) / 3.0, 1.0])
    away = np.array([-0.9, -1.0, 0.0]) * 2.0 * max(math.hypot(*truck_xy), math.hypot(*dig_xy))
    return layout(row(
        column(world_view(f"{machine} loading the truck", eye=target + away + [0.0, 0.0, 13.0], target=target),
               log_view(), shares=[4, 1]),
        column(tabs(series_view("soil per pass [l]", "/pass/bucket_l", "/pass/truck_l", "/pass/spill_l", whole=True),
                    series_view("time per pass [s]", "/pass/cycle_s", "/pass/script_s", whole=True),
                    series_view("cost per pass", "/pass/cost", whole=True)),
               series_view("soil [l]", "/soil/bucket_l", "/soil/truck_l"),
               tabs(series_view("joints [deg]", "/joint_deg/**"), series_view("cylinders [kN]", "/cylinder_kn/**"))),
        shares=[3, 2]))


class TruckLoadingRecorder(ExcavatorRecorder):
    """Records one truck-loading episode to ``path`` (see the module docstring).

    Args:
        path: the ``.rrd`` file to write (parent folders are created; an existing file is replaced).
        rate_hz: how often the machine's pose and the signals are sampled [Hz of simulated time].
        live: also stream the episode to the viewer at this gRPC URL.

    Raises:
        ExcavsimError: not an ``.rrd`` path or a rate that is not positive.
    """

    places = {constants.SOIL_BOX_BODY: "world/pit", "truck": "world/truck"}

    def __init__(self, path: str | os.PathLike | None, *, rate_hz: float = 10.0, live: str | None = None):
        # the pit's terrain is logged per pass (dug), not on a period: a period longer than any episode
        super().__init__(path, rate_hz=rate_hz, soil_period_s=1e12, live=live)
        self.cfg = None
        self._bed_m3: float | None = None  # the bed's volume at the last step [m^3] (a drop: a truck left)

    # -- the base's hooks ------------------------------------------------------------------------------
    def begin(self, world, cfg=None):
        self.cfg = cfg
        return super().begin(world)

    def config_text(self) -> str:
        cfg = self.cfg.model_dump_json() if hasattr(self.cfg, "model_dump_json") else repr(self.cfg)
        return f"machine: {self.machine}\ntask: truck_loading\ntruck: {self.world.truck!r}\nconfig: {cfg}\n"

    def blueprint(self):
        t = self.world.truck
        dig = getattr(self.cfg, "dig", None)  # the candidate digs' middle, for the camera
        if dig is not None:
            r, a = float(np.mean(dig.radii_m)), math.radians(float(np.mean(dig.swings_deg)))
            return truck_loading_blueprint(self.machine, (t.x_m, t.y_m), (r * math.cos(a), r * math.sin(a)))
        return truck_loading_blueprint(self.machine, (t.x_m, t.y_m))

    def setup(self) -> None:
        """The machine, the pit, the truck and the empty bed."""
        super().setup()
        for entity, (name, colour) in PASS_SERIES.items():  # points: one value a pass, at the pass's end on sim_time
            self.series_style(entity, name, colour, lines=False, points=True, marker_size=4.0)
        self.series_style("soil/truck_l", "soil in the truck [l]", (150, 100, 210))
        self._fill()

    def sample(self, world) -> dict:
        return {**super().sample(world), "truck_l": 1000.0 * world.bed.volume()}

    def send(self, batch: Batch) -> None:
        super().send(batch)
        self.scalar_columns("soil/truck_l", batch["truck_l"], batch.at)

    def ended(self, result) -> None:
        """The last fill, the episode's end in the log, the last sample and terrain."""
        self._fill()
        if result is not None:
            self.say(f"{result.end}: {result.reason}")
        else:
            self.say("the episode was abandoned", WARN)
        super().ended(result)

    # -- the episode's hooks ---------------------------------------------------------------------------
    def scanned(self, index, emap, bed_depth=None) -> None:
        """At each look: the bed as the mind's scanner mapped it (the fill's surface, NaN cells left out)."""
        if self.rec is None or bed_depth is None:
            return
        t = self.world.truck
        depth = np.asarray(bed_depth, float)
        nrows, ncols = depth.shape
        u = -0.5 * t.length_m + (np.arange(ncols) + 0.5) * t.length_m / ncols
        v = -0.5 * t.width_m + (np.arange(nrows) + 0.5) * t.width_m / nrows
        uu, vv = np.meshgrid(u, v)
        ok = np.isfinite(depth)  # in the truck's frame, as the fill
        self.at(self.world.time)
        self.points("world/truck/scan", np.stack([uu[ok], vv[ok], t.floor_m + depth[ok]], axis=1), radii=0.03,
                    colours=MAP_RGB)

    def stepped(self, world) -> None:
        """After a control step: the machine and the signals at ``rate_hz``; the fill when a truck left."""
        self.require_started("stepped")
        bed_m3 = world.bed.volume()  # it only grows (the bed catches, settling keeps it) until a truck leaves
        if self._bed_m3 is not None and bed_m3 < self._bed_m3 - 1e-9:
            self._fill()  # the full truck left, an empty one is in its place
        self._bed_m3 = bed_m3
        super().stepped(world)

    def dug(self, index: int, p) -> None:
        """After a pass: the pit's terrain, the bed's fill, the pass's metrics and its line of the log."""
        self.require_started("dug")
        w = self.world
        self.terrain()
        self._fill()
        truck_l = 1000.0 * w.bed.volume()
        self.at(w.time, **{"pass": int(index)})  # the pass and its end on sim_time
        values = {"pass/bucket_l": 1000.0 * p.bucket_m3, "pass/truck_l": truck_l, "pass/spill_l": 1000.0 * p.spill_m3,
                  "pass/cycle_s": p.cycle_s, "pass/script_s": p.script_s, "pass/cost": p.cost}
        for entity, value in values.items():
            if math.isfinite(value):
                self.scalar(entity, value)
        self.at(w.time)
        self.say(f"pass {index} ({p.source}): {p.cycle_s:.1f} s (dig {p.dig_s:.1f} s, swing-dump-return "
                 f"{p.script_s:.1f} s); bucket {1000 * p.bucket_m3:.0f} l, into the truck {1000 * p.bed_m3:.0f} l, "
                 f"spilled {1000 * p.spill_m3:.0f} l, the truck holds {truck_l:.0f} l",
                 INFO if p.outcome == "end" else WARN)

    # -- helpers -----------------------------------------------------------------------------------------
    def _fill(self) -> None:
        """The bed's fill (truth) as a mesh in the truck's frame (``world/truck``'s: the bed's centre on the
        ground, x along the truck, y across): a vertex at each fill cell's centre, at the fill's surface."""
        bed = self.world.bed
        u, v = bed.centres_local()
        self.at(self.world.time)
        self.grid_mesh("world/truck/fill", u, v, bed.fill, bed.cell, colours=FILL_RGB,
                       z_offset=self.world.truck.floor_m, fixed=True)
        self._bed_m3 = bed.volume()
