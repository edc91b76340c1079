"""The Rerun recording of a loading episode in MuJoCo (``task: pile_loading``; ``excavsim load --mujoco --record FILE.rrd``).

:class:`LoadingRecorder` is the episode's observer (:class:`~excavsim.tasks.pile_loading.task.LoadingObserver`:
``started(world, machine)``, ``scanned(index, emap, terrain)``, ``planned(index, plan, poses)``,
``stepped(world)``, ``dug(index, dig)``, ``finished(run)``), an
:class:`~excavsim.record.base.EpisodeRecorder` that adds the loading's entities. Timelines
``sim_time`` (duration) and ``dig`` (sequence; the samples carry ``step`` too). Entity tree::

    world                      ViewCoordinates (right-handed, z up), static
      <machine>/<body>         the machine's visual geoms, static in their body frames, and a Transform3D
                               per sample of each moving body
      box                      the lane's kerbs, static
      soil/truth               the true terrain (Mesh3D, its triangles once) at the start, after every scan and dig
      soil/scan                the elevation map of each scan
      plan/path                the planned tip path (pre-entry, approach, arc, lift-out), per plan
      exec/path                the executed tip path, per dig
    volumes/{lane,bucket,spoil,total}_m3   the soil's account [m^3] (truth; the sum is constant; the spoil
                               is the delivered and the spilled soil, which the log's dig lines give apart)
    truth/soil_force_n         |the soil's force on the bucket| [N] (truth)
    joints/<joint>             the joints [rad or m]
    config                     the machine and the scene, static
    log                        TextLog: the start, each plan and dig, the end
"""

from __future__ import annotations

import numpy as np
import yaml

from excavsim import constants
from excavsim.record.drawing import ERROR
from excavsim.record.geometry import MAP_RGB, SAND_RGB
from excavsim.record.base import Batch, EpisodeRecorder

PLAN_RGB = (230, 90, 40)
EXEC_RGB = (240, 240, 240)
VOLUMES = ("lane", "bucket", "spoil", "total")


def _in_the_plane(path: np.ndarray) -> np.ndarray:
    """A tip path (n, 2) in the machine's plane (x forward, z up) in the world (y = 0) [m]."""
    return np.stack([path[:, 0], np.zeros(len(path)), path[:, 1]], axis=1)


class LoadingRecorder(EpisodeRecorder):
    """Records one MuJoCo loading episode to ``path`` at ``rate_hz`` of simulated time (see the module
    docstring; the arguments are :class:`~excavsim.record.base.EpisodeRecorder`'s)."""

    sample_timelines = ("dig",)

    def begin(self, world, machine: str):
        self.machine = machine
        return world

    def config_text(self) -> str:
        scene = self.world.scene.model_dump(mode="json")
        return (f"# Loading from a pile lane, the front {self.machine}\n\n```yaml\n"
                f"{yaml.safe_dump({'machine': self.machine, 'scene': scene}, sort_keys=False)}```\n")

    def setup(self) -> None:
        world = self.world
        self._now()
        self.draw_bodies(world, self.machine, {constants.SOIL_BOX_BODY: "world/box"})
        self._log_truth()
        self.say(f"loading episode: front {self.machine}, lane {world.volumes().box:.3f} m^3 of soil")

    def sample(self, world) -> dict:
        v = world.volumes()
        return {"q": world.joint_angles(), "volumes": (v.box, v.bucket, v.spoil, v.total),
                "force": float(np.linalg.norm(world.contact.force)) if world.contact is not None else 0.0}

    def send(self, batch: Batch) -> None:
        at, q, vol = batch.at, batch["q"], batch["volumes"]
        for j, name in enumerate(self.world.joints):
            self.scalar_columns(f"joints/{name.removesuffix('_joint')}", q[:, j], at)
        for j, name in enumerate(VOLUMES):
            self.scalar_columns(f"volumes/{name}_m3", vol[:, j], at)
        self.scalar_columns("truth/soil_force_n", batch["force"], at)

    def ended(self, run) -> None:
        self._now()
        if run is None:  # the episode ended with an error: what was recorded is kept
            self.say("end: the episode ended with an error", ERROR)
            return
        self.say(f"end: {run.reason}; lane {run.start_m3:.3f} -> {run.end_m3:.3f} m^3, {len(run.digs)} digs")

    # -- the episode's hooks ---------------------------------------------------------------------------
    def scanned(self, index: int, emap, terrain) -> None:
        self._now()
        self.height_map("world/soil/scan", emap, colours=MAP_RGB)
        self._log_truth()

    def planned(self, index: int, plan, poses: np.ndarray) -> None:
        self.sequence["dig"] = index
        self._now()
        a = plan.action
        self.lines("world/plan/path", [_in_the_plane(poses)], colours=PLAN_RGB, radii=0.02, labels=[f"plan {index}"])
        self.clear("world/exec/path")
        self.say(f"plan {index}: k {a.k:.2f} m, h {a.h:.2f} m, alpha {np.degrees(a.alpha):.0f} deg, d1 {a.d1:.2f} m, "
                 f"r {a.r:.2f} m, {plan.volume:.3f} m^2 of the section ({plan.reason})")

    def dug(self, index: int, dig) -> None:
        self._now()
        if len(dig.tip_path):
            self.lines("world/exec/path", [_in_the_plane(dig.tip_path)], colours=EXEC_RGB, radii=0.02)
        self.say(f"dig {index}: planned {dig.planned_m3:.3f} m^3, in the bucket at lift-out {dig.bucket_m3:.3f}, "
                 f"delivered {dig.delivered_m3:.3f}, spilled {dig.spilled_m3:.3f}, lane {dig.lane_m3:.3f} "
                 f"({dig.section} section)")
        self._log_truth()

    # -- helpers -----------------------------------------------------------------------------------------
    def _now(self) -> None:
        self.at(self.world.time, dig=self.sequence["dig"])

    def _log_truth(self) -> None:
        self.heightfield("world/soil/truth", self.world.soil.grid, colours=SAND_RGB)
