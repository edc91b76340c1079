"""Write the MJCF models of the two loading machines, models/loader/loader.xml and models/shovel/shovel.xml.

The kinematic numbers come from ``configs/pile_loading_planar.yaml`` (the machines of excavsim.robot.loaders, whose
closed forms a test holds equal to MuJoCo's kinematics of these files); the bucket of each is designed
here: a floor of the configured length, a rounded heel and a back wall whose height gives the bucket a
heaped capacity (``configs/scene.yaml``'s ``heaped_capacity_factor`` times the struck one) equal to the
machine's ``capacity_units`` over the lane's width (``BUCKET_WIDTH_M``). Run from the repository root:

    .venv/bin/python scripts/make_loading_models.py          # write both files
    .venv/bin/python scripts/make_loading_models.py --check  # exit 1 if a committed file differs
"""

from __future__ import annotations

import argparse
import math
import pathlib
import sys

import numpy as np

from excavsim import constants
from excavsim.config import load_scene_config
from excavsim.tasks.pile_loading.planar import load_loading_config

BUCKET_WIDTH_M = 0.95  # the pile lane's width (models/pile_box): the bucket spans it
HEEL_RADIUS_FRACTION = 0.2  # heel corner radius over the floor length (assumed)


def bucket_profile(floor: float, wall: float) -> np.ndarray:
    """(7, 2) profile in (a, b): a along the floor from the edge (heel at -floor), b into the bucket."""
    rc = HEEL_RADIUS_FRACTION * floor
    pts = [(0.0, 0.0)]
    for th in np.radians([-90.0, -120.0, -150.0, -180.0]):
        pts.append((-floor + rc + rc * math.cos(th), rc + rc * math.sin(th)))
    pts += [(-floor, 0.5 * (rc + wall)), (-floor, wall)]
    return np.array(pts)


def polygon_area(p: np.ndarray) -> float:
    x, z = p[:, 0], p[:, 1]
    return abs(float((x * np.roll(z, -1) - np.roll(x, -1) * z).sum())) / 2.0


def wall_for(floor: float, struck_m2: float) -> float:
    """The back wall's height whose interior (profile closed by the strike line) has area ``struck_m2``."""
    lo, hi = HEEL_RADIUS_FRACTION * floor * 1.01, 10.0
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if polygon_area(bucket_profile(floor, mid)) < struck_m2 else (lo, mid)
    return 0.5 * (lo + hi)


def f(*v) -> str:
    return " ".join(f"{x:.12g}" if abs(x) > 1e-12 else "0" for x in v)


def bucket_xml(name: str, link_angle: float, link: float, mu: float, floor: float, capacity_m2: float,
               heaped: float, mass: float, indent: str) -> tuple[str, float]:
    """The bucket's geoms, sites and inertial in its body frame (the pin at the origin; with the joint at 0 the
    link from pin to tip points at ``link_angle`` in the (x, z) plane); returns the XML and the struck capacity."""
    struck_m2 = capacity_m2 / heaped
    wall = wall_for(floor, struck_m2)
    prof = bucket_profile(floor, wall)
    tip = link * np.array([math.cos(link_angle), math.sin(link_angle)])
    ua = link_angle - mu
    u = np.array([math.cos(ua), math.sin(ua)])
    n = np.array([-u[1], u[0]])
    xz = tip + prof[:, :1] * u + prof[:, 1:] * n
    centroid = xz.mean(axis=0)
    w = BUCKET_WIDTH_M
    lines = [f'{indent}<inertial pos="{f(centroid[0], 0, centroid[1])}" mass="{mass:g}" '
             f'diaginertia="{f(mass * 0.15, mass * 0.2, mass * 0.15)}"/>']
    lines.append(f'{indent}<site name="{constants.FT_SITE}" class="sensor_site"/>')
    # visual plates: floor, back wall, the two sides (a box spanning the profile's extent), the pin boss
    heel = tip - floor * u
    top = heel + wall * n
    for gname, a, b in (("bucket_floor", tip, heel), ("bucket_back", heel, top)):
        lines.append(f'{indent}<geom name="{gname}" class="visual" type="capsule" size="0.03" '
                     f'fromto="{f(a[0], -w / 2, a[1], b[0], -w / 2, b[1])}" material="bucket_steel"/>')
        mid = 0.5 * (a + b)
        lines.append(f'{indent}<geom name="{gname}_plate" class="visual" type="box" '
                     f'size="{f(0.5 * np.hypot(*(b - a)), w / 2, 0.015)}" pos="{f(mid[0], 0, mid[1])}" '
                     f'xyaxes="{f((b - a)[0], 0, (b - a)[1], 0, 1, 0)}" material="bucket_steel"/>')
    for side, y in (("left", w / 2), ("right", -w / 2)):
        c = 0.5 * (tip + top)
        d = top - tip
        lines.append(f'{indent}<geom name="bucket_side_{side}" class="visual" type="box" '
                     f'size="{f(0.5 * np.hypot(*d), 0.01, 0.25 * wall)}" pos="{f(c[0], y, c[1])}" '
                     f'xyaxes="{f(d[0], 0, d[1], 0, 1, 0)}" material="bucket_steel"/>')
    lines.append(f'{indent}<geom name="bucket_boss" class="visual" type="cylinder" size="0.08 {0.5 * w:g}" '
                 f'zaxis="0 1 0" material="dark"/>')
    lines.append(f'{indent}<geom name="bucket_link" class="visual" type="capsule" size="0.05" '
                 f'fromto="{f(0, 0, 0, top[0], 0, top[1])}" material="dark"/>')
    for i, p in enumerate(xz):
        lines.append(f'{indent}<site name="{constants.BUCKET_PROFILE_SITE_PREFIX}{i}" class="profile" '
                     f'pos="{f(p[0], 0, p[1])}"/>')
    # tip frame: x along the floor from heel to edge, z into the bucket, y = z x x
    y = np.cross([n[0], 0, n[1]], [u[0], 0, u[1]])
    lines.append(f'{indent}<site name="{constants.BUCKET_TIP_SITE}" class="tip" pos="{f(tip[0], 0, tip[1])}" '
                 f'xyaxes="{f(u[0], 0, u[1], *y)}"/>')
    return "\n".join(lines), struck_m2 * w


HEADER = """<mujoco model="{model}">
  <!--
    {title} for loading from a pile (Singh 1995 §3.5, §4.1-4.2, App. A1-2, Table A1-3).
    Generated by scripts/make_loading_models.py from configs/pile_loading_planar.yaml (kinematics) and
    configs/scene.yaml (heaped capacity factor): do not edit by hand. The machine only:
    scene.xml adds the pile lane (models/pile_box), light and keyframes. See README.md.
    Planar: every revolute joint turns about -y of its body, so a positive angle turns the next link
    counter-clockwise in the (x, z) plane; the machine's geoms are visual only (no contacts: the world's
    soil model computes every bucket-soil force, and the base rides its slide joint).
  -->
  <compiler angle="radian" autolimits="true"/>

  <default>
    <default class="{model}">
      <joint damping="{damping:g}" armature="{armature:g}"/>
      <default class="visual">
        <geom contype="0" conaffinity="0" group="2" density="0"/>
      </default>
      <default class="sensor_site">
        <site group="4" size="0.03" rgba="1 0.3 0.1 1"/>
      </default>
      <default class="profile">
        <site group="4" size="0.015" rgba="0.1 0.8 1 1"/>
      </default>
      <default class="tip">
        <site group="4" size="0.03" rgba="1 0 0 1"/>
      </default>
    </default>
  </default>

  <asset>
    <material name="paint" rgba="{paint}"/>
    <material name="dark" rgba="0.15 0.15 0.17 1"/>
    <material name="bucket_steel" rgba="0.55 0.55 0.58 1"/>
  </asset>
"""

FOOTER = """
  <custom>
    <!-- Generated: inner width [m] (the lane's), struck capacity [m^3]. -->
    <numeric name="{wname}" data="{width:g}"/>
    <numeric name="{cname}" data="{cap:.6g}"/>
  </custom>

  <!--
    Hydraulic cylinders as position servos (kp, kv) clipped at the relief force/torque (forcerange).
    Reference: sized (assumed) so that the wedge-model forces of a 1 m deep cut in sand move the
    set-point by millimetres; the thesis gives no machine forces.
  -->
  <actuator>
{actuators}
  </actuator>

  <sensor>
    <force name="{fname}" site="{site}"/>
    <torque name="{tname}" site="{site}"/>
  </sensor>
</mujoco>
"""


def actuator(name: str, joint: str, kp: float, kv: float, force: float) -> str:
    return (f'    <position name="{name}" class="{{cls}}" joint="{joint}" kp="{kp:g}" kv="{kv:g}" '
            f'forcerange="{-force:g} {force:g}" inheritrange="1"/>')


def assemble(model: str, title: str, paint: str, body: str, cap: float, acts: str) -> str:
    """A machine's MJCF file: the header, its bodies, and the footer with the bucket's numerics, the
    actuators and the F/T sensors."""
    return (HEADER.format(model=model, title=title, damping=2e3, armature=200, paint=paint) + body
            + FOOTER.format(wname=constants.BUCKET_WIDTH_NUMERIC, width=BUCKET_WIDTH_M,
                            cname=constants.BUCKET_CAPACITY_NUMERIC, cap=cap, actuators=acts,
                            fname=constants.FT_FORCE_SENSOR, tname=constants.FT_TORQUE_SENSOR, site=constants.FT_SITE))


def loader_xml(cfg, heaped: float) -> str:
    m = cfg.machines.loader
    mu = math.radians(m.mu_deg)
    r2 = [math.radians(v) for v in m.theta2_range_deg]
    r3 = [math.radians(v) for v in m.theta3_range_deg]
    b, cap = bucket_xml("loader", -math.pi / 2, m.l4, mu, m.floor, m.capacity_units * cfg.units_m2, heaped, 900.0,
                        " " * 10)
    wx = m.wheel_front - 0.7
    ib = 1500 * m.l3 ** 2 / 12
    body = f"""
  <worldbody>
    <!-- Reference: Table A1-3's P-R-R chain. The chassis sits at x = l2 = {m.l2:g} m when d1 = 0 and the travel
         joint d1 moves it along -x (the shoulder at x = l2 - d1); the shoulder is -l1 = {-m.l1:g} m up. -->
    <body name="chassis" pos="{m.l2:g} 0 0" childclass="loader">
      <inertial pos="-1.2 0 0.9" mass="12000" diaginertia="4000 9000 9000"/>
      <joint name="travel_joint" type="slide" axis="-1 0 0" range="{m.d1_range[0]:g} {m.d1_range[1]:g}"
             damping="2e4" armature="0"/>
      <geom name="frame" class="visual" type="box" size="1.5 0.6 0.35" pos="-1.3 0 0.95" material="paint"/>
      <geom name="cab" class="visual" type="box" size="0.5 0.55 0.6" pos="-1.6 0 1.9" material="paint"/>
      <geom name="engine" class="visual" type="box" size="0.6 0.5 0.45" pos="-2.6 0 1.45" material="paint"/>
      <!-- Reference: the front wheels' front {m.wheel_front:g} m ahead of the shoulder (wheel_front). -->
      <geom name="wheel_front_left" class="visual" type="cylinder" size="0.7 0.15" pos="{wx:g} 0.7 0.7"
            zaxis="0 1 0" material="dark"/>
      <geom name="wheel_front_right" class="visual" type="cylinder" size="0.7 0.15" pos="{wx:g} -0.7 0.7"
            zaxis="0 1 0" material="dark"/>
      <geom name="wheel_rear_left" class="visual" type="cylinder" size="0.7 0.15" pos="-2.4 0.7 0.7" zaxis="0 1 0"
            material="dark"/>
      <geom name="wheel_rear_right" class="visual" type="cylinder" size="0.7 0.15" pos="-2.4 -0.7 0.7" zaxis="0 1 0"
            material="dark"/>
      <body name="boom" pos="0 0 {-m.l1:g}">
        <!-- theta2: the boom's turn from straight down, counter-clockwise (Table A1-3's pi + theta2 row). -->
        <inertial pos="0 0 {-m.l3 / 2:g}" mass="1500" diaginertia="{ib:.6g} {ib:.6g} 50"/>
        <joint name="boom_joint" axis="0 -1 0" range="{r2[0]:.12g} {r2[1]:.12g}"/>
        <geom name="boom_arm" class="visual" type="capsule" size="0.12" fromto="0 0.35 0 0 0.35 {-m.l3:g}"
              material="paint"/>
        <geom name="boom_arm2" class="visual" type="capsule" size="0.12" fromto="0 -0.35 0 0 -0.35 {-m.l3:g}"
              material="paint"/>
        <body name="{constants.BUCKET_BODY}" pos="0 0 {-m.l3:g}">
          <!-- theta3: the bucket link's turn from the boom; l4 = {m.l4:g} m pin to tip, mu = {m.mu_deg:g} deg. -->
          <joint name="bucket_joint" axis="0 -1 0" range="{r3[0]:.12g} {r3[1]:.12g}"/>
{b}
        </body>
      </body>
    </body>
  </worldbody>
"""
    acts = "\n".join([actuator("travel", "travel_joint", 3e6, 4e5, 4e5), actuator("boom", "boom_joint", 5e7, 4e6, 2e6),
                      actuator("bucket", "bucket_joint", 1e7, 4e5, 6e5)]).replace("{cls}", "loader")
    return assemble("loader", "A front loader (wheeled base, boom, bucket)", "0.93 0.72 0.1 1", body, cap, acts)


def shovel_xml(cfg, heaped: float) -> str:
    m = cfg.machines.shovel
    mu = math.radians(m.mu_deg)
    r = [[math.radians(v) for v in rr] for rr in (m.theta1_range_deg, m.theta2_range_deg, m.theta3_range_deg)]
    b, cap = bucket_xml("shovel", 0.0, m.l3, mu, m.floor, m.capacity_units * cfg.units_m2, heaped, 600.0, " " * 12)
    i1, i2 = 2500 * m.l1 ** 2 / 12, 1200 * m.l2 ** 2 / 12
    body = f"""
  <worldbody>
    <!-- Reference: three revolute joints (boom, stick, bucket) on a tracked base placed between digs (§4.2);
         the base joint's value is the boom pivot's x; the pivot is {m.shoulder_height:g} m up. -->
    <body name="base" childclass="shovel">
      <inertial pos="-1.0 0 1.0" mass="20000" diaginertia="8000 15000 15000"/>
      <joint name="base_joint" type="slide" axis="1 0 0" range="-30 30" damping="4e4" armature="0"/>
      <!-- Reference: the tracks' front {m.track_front:g} m ahead of the pivot (track_front). -->
      <geom name="tracks" class="visual" type="box" size="{(m.track_front + 2.5) / 2:g} 0.75 0.45"
            pos="{(m.track_front - 2.5) / 2:g} 0 0.45" material="dark"/>
      <geom name="house" class="visual" type="box" size="1.6 0.7 0.6" pos="-1.3 0 1.5" material="paint"/>
      <geom name="cab" class="visual" type="box" size="0.45 0.5 0.55" pos="-0.2 0.3 2.5" material="paint"/>
      <body name="boom" pos="0 0 {m.shoulder_height:g}">
        <inertial pos="{m.l1 / 2:g} 0 0" mass="2500" diaginertia="60 {i1:.6g} {i1:.6g}"/>
        <joint name="boom_joint" axis="0 -1 0" range="{r[0][0]:.12g} {r[0][1]:.12g}"/>
        <geom name="boom_arm" class="visual" type="capsule" size="0.18" fromto="0 0 0 {m.l1:g} 0 0" material="paint"/>
        <body name="stick" pos="{m.l1:g} 0 0">
          <inertial pos="{m.l2 / 2:g} 0 0" mass="1200" diaginertia="30 {i2:.6g} {i2:.6g}"/>
          <joint name="stick_joint" axis="0 -1 0" range="{r[1][0]:.12g} {r[1][1]:.12g}"/>
          <geom name="stick_arm" class="visual" type="capsule" size="0.12" fromto="0 0 0 {m.l2:g} 0 0"
                material="paint"/>
          <body name="{constants.BUCKET_BODY}" pos="{m.l2:g} 0 0">
            <joint name="bucket_joint" axis="0 -1 0" range="{r[2][0]:.12g} {r[2][1]:.12g}"/>
{b}
          </body>
        </body>
      </body>
    </body>
  </worldbody>
"""
    acts = "\n".join([actuator("base", "base_joint", 5e6, 8e5, 1e6), actuator("boom", "boom_joint", 8e7, 6e6, 3e6),
                      actuator("stick", "stick_joint", 3e7, 2e6, 1.5e6),
                      actuator("bucket", "bucket_joint", 5e6, 2e5, 4e5)]).replace("{cls}", "shovel")
    return assemble("shovel", "A front shovel (tracked base, boom, stick, bucket)", "0.85 0.3 0.15 1", body, cap, acts)


def generated() -> dict[pathlib.Path, str]:
    cfg = load_loading_config()
    heaped = load_scene_config().bucket.heaped_capacity_factor
    return {constants.MODELS_DIR / "loader" / "loader.xml": loader_xml(cfg, heaped),
            constants.MODELS_DIR / "shovel" / "shovel.xml": shovel_xml(cfg, heaped)}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="compare with the committed files instead of writing")
    args = ap.parse_args(argv)
    bad = 0
    for path, text in generated().items():
        if args.check:
            if not path.exists() or path.read_text() != text:
                print(f"{path} differs from the generator's output")
                bad = 1
        else:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text)
            print(f"wrote {path}")
    return bad


if __name__ == "__main__":
    sys.exit(main())
