"""Bring your own MJCF machine to the soil: a gantry with a bucket digs the testbed's soil box.

    python examples/own_machine.py

The machine here is the smallest one that digs: two slides (x along the box, z up) and a hinge carrying a
bucket, driven by position servos. Anything else works the same way (see docs/concepts/own-machine.md):
the world's soil model finds the bucket through a handful of names, not through the machine.

1. The machine's MJCF has a body called ``bucket`` with, in its frame and in its mid-plane (y = 0), the
   ``bucket_profile_0`` .. ``bucket_profile_6`` sites (the cutting edge first, then the floor, the arc and
   the back wall's top), a ``bucket_tip`` site (x along the blade towards the edge, z into the bucket) and
   two numerics, ``bucket_width`` and ``bucket_capacity``. Here :class:`BucketShape` lays them out.
2. A scene includes the machine and a soil file (``models/soil_box/soil_box.xml`` here).
3. Each control step: ``SoilModel.step`` reads the bucket, cuts and fills, and returns its wrench on the
   bucket; apply it through ``xfrc_applied`` and step MuJoCo.
"""

from __future__ import annotations

import numpy as np

import mujoco
from excavsim import constants
from excavsim.config import get_soil, load_scene_config
from excavsim.robot.excavators import BucketShape
from excavsim.world.soil import SoilModel

SHAPE = BucketShape(width_m=0.30, blade_m=0.20, arc_m=0.12, back_m=0.35, pin_m=0.40, mass_kg=30.0)


def machine_xml(shape: BucketShape) -> str:
    """A gantry carrying a bucket, with the soil model's names on the bucket."""
    profile = shape.to_bucket_frame(shape.profile())
    a = shape.blade_angle
    sites = "\n".join(f'<site name="bucket_profile_{i}" pos="{x:.6f} 0 {z:.6f}"/>' for i, (x, z) in enumerate(profile))
    return f"""<mujoco model="gantry">
  <worldbody>
    <body name="carriage" pos="1.0 0 1.6">
      <joint name="x" type="slide" axis="1 0 0" range="-0.5 2.5" damping="2000"/>
      <geom type="box" size="0.1 0.1 0.1" mass="200" contype="0" conaffinity="0"/>
      <body name="mast">
        <joint name="z" type="slide" axis="0 0 1" range="-1.5 0.5" damping="2000"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.04" mass="50" contype="0" conaffinity="0"/>
        <body name="bucket" pos="0 0 -0.3" euler="0 1.5708 0">
          <joint name="curl" axis="0 -1 0" range="-2.5 1.0" damping="200"/>
          <geom type="box" size="0.2 {shape.width_m / 2:.3f} 0.02" pos="0.2 0 0.1" mass="{shape.mass_kg}"
                contype="0" conaffinity="0"/>
          {sites}
          <site name="bucket_tip" pos="{profile[0][0]:.6f} 0 {profile[0][1]:.6f}"
                xyaxes="{np.cos(a):.6f} 0 {np.sin(a):.6f} 0 -1 0"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <position joint="x" kp="2e5" kv="2e4" forcerange="-2e4 2e4"/>
    <position joint="z" kp="2e5" kv="2e4" forcerange="-2e4 2e4"/>
    <position joint="curl" kp="2e4" kv="2e3" forcerange="-5e3 5e3"/>
  </actuator>
  <custom>
    <numeric name="bucket_width" data="{shape.width_m}"/>
    <numeric name="bucket_capacity" data="{shape.struck_capacity_m3():.6f}"/>
  </custom>
</mujoco>"""


SCENE = """<mujoco model="gantry scene">
  <include file="gantry.xml"/>
  <include file="soil_box.xml"/>
  <option timestep="0.002" integrator="implicitfast"/>
</mujoco>"""


def dig(seconds_per_leg: float = 2.0, soil: str = "dry_sand", seed: int = 0) -> dict[str, float]:
    """Lower the bucket into the box, drag it 1 m, curl it up; the volumes and the largest soil force."""
    assets = {"gantry.xml": machine_xml(SHAPE).encode(), "soil_box.xml": constants.SOIL_BOX_XML.read_bytes()}
    model = mujoco.MjModel.from_xml_string(SCENE, assets)
    data = mujoco.MjData(model)
    scene = load_scene_config()
    soil_model = SoilModel(model, scene, get_soil(soil), np.random.default_rng(seed))
    bucket = model.body("bucket").id
    dt = 0.02
    substeps = int(round(dt / model.opt.timestep))
    start = soil_model.volumes()
    # The bucket hangs from the mast with its blade pointing back and down (-x), as a backhoe's does, so it
    # digs while the carriage moves towards -x. Targets (x slide, z slide, curl): over the box, down until
    # the cutting edge is 0.15 m below the surface, 1.2 m along, curled up (negative) and lifted out.
    edge_z0 = 1.6 - 0.3 - SHAPE.pin_to_tip_m  # the cutting edge's height with both slides at zero
    z_dig = scene.initial_soil_height_m - 0.15 - edge_z0
    legs = [(1.8, z_dig + 0.3, 0.0), (1.8, z_dig, 0.0), (0.6, z_dig, 0.0), (0.6, z_dig + 0.05, -1.6), (0.6, 0.3, -1.6)]
    peak = 0.0
    for target in legs:
        data.ctrl[:] = target
        for _ in range(int(seconds_per_leg / dt)):
            contact = soil_model.step(data, dt)
            data.xfrc_applied[bucket] = contact.wrench
            mujoco.mj_step(model, data, substeps)
            peak = max(peak, float(np.linalg.norm(contact.cutting_force)))
    end = soil_model.volumes()
    warnings = int(sum(w.number for w in data.warning))
    return {"in_bucket_m3": end.bucket, "cut_from_box_m3": start.box - end.box,
            "volume_error_m3": end.total - start.total, "peak_cutting_force_n": peak, "mujoco_warnings": warnings}


if __name__ == "__main__":
    for key, value in dig().items():
        print(f"{key}: {value:.4g}")
