"""Rerun recordings of an excavator in its pit (``models/tb035``, ``models/excavator_25t`` in
:class:`~excavsim.world.hydraulics.ExcavatorWorld`): the machine's bodies and cylinders, and the soil.

:class:`ExcavatorRecorder` is an :class:`~excavsim.record.base.EpisodeRecorder` of a run stepped step
by step (``started(world)``, ``stepped(world)`` after every control step, ``finished(...)``): the
teleoperation of ``excavsim playback --machine tb035 --teleop --record FILE.rrd``, or any loop that
steps the world (the ``excavsim/ExcavatorJoint-v0`` environment's world is ``env.unwrapped.sim``); the
truck-loading task's recorder adds its truck to it. Timeline ``sim_time`` (duration; the samples carry
``step`` too). Entity tree::

    world                        ViewCoordinates (right-handed, z up), static
      <machine>/<body>           Transform3D of each moving body (xpos/xquat) at rate_hz; static for the base
      <machine>/<body>/<geom>    the visual geoms in the body frame (boxes, capsules, ...), static
      <machine>/cylinders        LineStrips3D: each cylinder pin to pin (its tendon), at rate_hz
      pit/<geom>                 the ground slabs around the pit, static
      soil/truth                 Mesh3D of the true heightfield at the start, every soil_period_s and at the end
    joint_deg/<function>         swing, boom, stick, bucket angles [deg], rate_hz
    cylinder_kn/<function>       swing torque [kN m] and cylinder forces [kN] (positive pushes), rate_hz
    soil/bucket_l                soil in the bucket [l] (truth), rate_hz
    soil/force_n                 |soil force on the bucket| [N] (truth), rate_hz
    config                       the machine and the seed, static
"""

from __future__ import annotations

import os

import numpy as np

from excavsim import constants
from excavsim.errors import ConfigError
from excavsim.record.geometry import SAND_RGB
from excavsim.record.base import Batch, EpisodeRecorder

FUNCTIONS = ("swing", "boom", "stick", "bucket")
FUNCTION_RGB = ((31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40))
CYLINDER_RGB = (170, 170, 180)


class ExcavatorRecorder(EpisodeRecorder):
    """Records one excavator run to ``path`` (an ``.rrd`` file; parent folders are created).

    Args:
        path: the recording to write; an existing file is replaced.
        rate_hz: how often the machine's pose and the signals are sampled [Hz of simulated time].
        soil_period_s: how often the true terrain is logged [s of simulated time].
        seed: the run's seed (part of the recording id).
        live: also stream the run to the viewer at this gRPC URL.

    Raises:
        ExcavsimError: not an ``.rrd`` path, a rate or period that is not positive, or a second start.
    """

    #: bodies drawn at a place of their own rather than under the machine (by body name)
    places = {constants.SOIL_BOX_BODY: "world/pit"}

    def __init__(self, path: str | os.PathLike | None, *, rate_hz: float = 10.0, soil_period_s: float = 1.0,
                 seed: int = 0, live: str | None = None):
        super().__init__(path, rate_hz=rate_hz, seed=seed, live=live)
        if not (np.isfinite(soil_period_s) and soil_period_s > 0):
            raise ConfigError(f"{type(self).__name__}: soil_period_s must be a positive number [s]; given "
                              f"{soil_period_s!r}")
        self.soil_period_s = float(soil_period_s)
        self._next_soil = 0.0

    def begin(self, world, *args):
        self.machine = world.spec.name
        self._tendons = [world.model.tendon(f"{f}_cylinder").id for f in FUNCTIONS[1:]]
        return world

    def config_text(self) -> str:
        return f"machine: {self.machine}\nseed: {self.seed}\n"

    def setup(self) -> None:
        """The static scene (geoms, pit), the series' styles, the first sample and terrain."""
        world = self.world
        self.draw_bodies(world, self.machine, self.places)
        for f, colour in zip(FUNCTIONS, FUNCTION_RGB):
            self.series_style(f"joint_deg/{f}", f"{f} [deg]", colour)
            self.series_style(f"cylinder_kn/{f}", f"{f} [{'kN m' if f == 'swing' else 'kN'}]", colour)
        self.series_style("soil/bucket_l", "soil in the bucket [l]", (245, 160, 40))
        self.series_style("soil/force_n", "|soil force on the bucket| [N]", (250, 250, 250))
        self.take_sample(world)
        self.terrain()

    def stepped(self, world) -> None:
        """After a control step: a sample when ``rate_hz`` says so, the terrain every ``soil_period_s``."""
        super().stepped(world)
        if float(world.time) + 1e-9 >= self._next_soil:
            self.terrain()

    def sample(self, world) -> dict:
        d = world.data
        strips = [d.wrap_xpos[d.ten_wrapadr[ten]:d.ten_wrapadr[ten] + d.ten_wrapnum[ten]].reshape(-1, 3).copy()
                  for ten in self._tendons]
        wrench = world.contact.wrench if world.contact is not None else np.zeros(6)
        return {"cylinders": strips, "q": world.joint_angles(), "forces": world.cylinder_forces(),
                "bucket_l": 1000.0 * float(world.soil.volumes().bucket), "force_n": float(np.linalg.norm(wrench[:3]))}

    def send(self, batch: Batch) -> None:
        at = batch.at
        self.line_columns(f"world/{self.machine}/cylinders", batch.rows("cylinders"), colour=CYLINDER_RGB,
                          radius=0.02, at=at)
        q, forces = batch["q"], batch["forces"]
        for j, f in enumerate(FUNCTIONS):
            self.scalar_columns(f"joint_deg/{f}", np.degrees(q[:, j]), at)
            self.scalar_columns(f"cylinder_kn/{f}", forces[:, j] / 1000.0, at)
        self.scalar_columns("soil/bucket_l", batch["bucket_l"], at)
        self.scalar_columns("soil/force_n", batch["force_n"], at)

    def ended(self, result) -> None:
        """The last sample and terrain (``result``, the world or the episode's result, is not needed)."""
        self.take_sample(self.world)
        self.flush()
        self.terrain()

    def terrain(self) -> None:
        """The pit's true terrain now; the next one after ``soil_period_s``."""
        t = float(self.world.time)
        self._next_soil = t + self.soil_period_s
        self.at(t)
        self.heightfield("world/soil/truth", self.world.soil.grid, colours=SAND_RGB)
