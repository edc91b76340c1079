"""Write the excavator models (``models/tb035/``, ``models/excavator_25t/``) from their specs.

Every number comes from :mod:`excavsim.robot.excavators` (sources in each model's README); this script
only lays them out as MJCF, so that the closed forms the tests check against and the files are one set of
numbers. A test fails when a committed file differs from what this script writes.

Layout of ``<name>.xml`` (the machine only):

* ``base`` (tracks; no joint: the machine stands still while it digs), ``upper`` (``swing_joint`` about
  +z, the cab with the ``cab_scanner_left``/``cab_scanner_right`` sites, two range finders as on
  Rowe 1997 §6.1's simulated machine, Fig. 10), ``boom``, ``stick`` and ``bucket`` (hinges about -y,
  counter-clockwise positive in the arm plane), and the bucket linkage's ``rocker`` and ``link``
  bodies, whose loop is closed by an ``equality/connect`` from the link's end to the bucket's pin.
* Bodies are written in the reference pose (``spec.ref``, the middle of each range) with the joints'
  ``ref`` set to it, so ``qpos0`` is that pose and the linkage is closed there.
* Each cylinder is a spatial tendon between its two pin sites (``*_cylinder_base``, ``*_cylinder_rod``):
  MuJoCo computes its length and moment arm. Its actuator is a ``general`` integrator servo:
  the control is the rate of the length set-point (ctrlrange: the pump's flow over the piston or annulus
  area), the activation is the set-point minus the reference pose's length (held within the stroke),
  the force ``kp (set-point - L) - kv dL/dt`` is clipped at the relief forces (forcerange:
  ``-p A_annulus .. p A_piston``). The swing's actuator is the same law on the swing joint with the
  swing motor's torque and speed.
* Sensors: ``ft_force``/``ft_torque`` at ``ft_mount`` (on the bucket pin: the wrench between stick and
  bucket; not the link's load path, which enters the bucket at the link pin, so it is not the soil's wrench:
  measured holding still in the air, 36 kN on a 0.8 kN bucket), and ``*_cylinder_force`` (each cylinder's force, what a pressure
  transducer pair reads).

Usage: python scripts/make_excavators.py [--check]
"""

from __future__ import annotations

import argparse
import math
import pathlib
import sys

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
# The rocker's and link's armature at the TB035's scale [kg m^2] (assumed): it stands in for the bucket
# cylinder's rod and oil column, which move with the rocker and are not bodies of the model. At 0.5 the
# bucket servo (stiff, on a 6 kg rocker) limit-cycled between its relief forces with the arm held still in
# the air (bucket up to 4 rad/s on the TB035, 1.4 rad/s on the 25 t); at 5 both settle (< 0.01 rad/s).
LINKAGE_ARMATURE = 5.0
sys.path.insert(0, str(ROOT))

from excavsim.robot.excavators import MACHINES, ExcavatorSpec  # noqa: E402

MODELS = ROOT / "models"


def f(*v) -> str:
    """Numbers as MJCF text (12 significant digits: the tests hold the files to the closed forms at 1e-9 m)."""
    return " ".join(f"{x:.12g}" for x in np.ravel(v))


def quat_y(angle: float) -> str:
    """The quaternion of a turn by ``angle`` about -y (counter-clockwise in the arm plane)."""
    return f(math.cos(angle / 2), 0.0, -math.sin(angle / 2), 0.0)


def box_inertia(mass: float, size: tuple[float, float, float]) -> str:
    """Diagonal inertia of a solid box of full extents ``size`` [kg m^2]."""
    x, y, z = size
    return f(mass * (y * y + z * z) / 12, mass * (x * x + z * z) / 12, mass * (x * x + y * y) / 12)


def rot2(a: float, v) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def xz(v) -> str:
    """A 2-D (x, z) point as an MJCF position in the arm plane."""
    return f(v[0], 0.0, v[1])


def machine_xml(s: ExcavatorSpec) -> str:
    a = s.arm
    ref = s.ref
    m = s.masses_kg
    b = s.bucket
    l1, l2, l3 = a.boom_m, a.stick_m, a.bucket_m
    w = b.width_m
    scale = l2 / 1.4  # visual sizes relative to the TB035's
    lk = s.linkage
    rho = float(lk.rocker_angle(ref[3]))
    lam = float(lk.link_angle(ref[3]))
    k = np.array(lk.rocker_pivot)
    profile = b.to_bucket_frame(b.profile())
    tip = profile[0]
    ba = b.blade_angle
    # collision boxes along the bucket's outer plates (the profile's coarse segments)
    coarse = b.to_bucket_frame(b.profile(n_arc=2))
    boxes = []
    t = 0.02 * scale
    for i, (p0, p1) in enumerate(zip(coarse[:-1], coarse[1:])):
        mid, d = (p0 + p1) / 2, p1 - p0
        length = float(np.linalg.norm(d))
        xa = d / length
        boxes.append(f'<geom name="bucket_collision_{i}" class="collision" type="box" '
                     f'size="{f(length / 2, w / 2 + t, t)}" pos="{xz(mid)}" xyaxes="{f(xa[0], 0, xa[1], 0, 1, 0)}"/>')
    centroid = profile.mean(axis=0)
    boom_a, boom_b = s.boom_pins.parent_pin, s.boom_pins.child_pin
    stick_a, stick_b = s.stick_pins.parent_pin, s.stick_pins.child_pin
    foot = np.array(a.boom_foot) - [0.0, s.upper_z_m]  # boom foot in the upper's frame
    kp = {fn: s.cylinder(fn).force_limits(s.relief_pa)[1] / s.servo_error_m for fn in ("boom", "stick", "bucket")}
    swing_t = s.swing_motor.torque_limit()
    kp["swing"] = swing_t / 0.01  # full torque at 0.01 rad of error
    l0 = {fn: float(s.cylinder_length(fn, ref[j])) for j, fn in ((1, "boom"), (2, "stick"), (3, "bucket"))}
    l0["swing"] = 0.0

    def actuator(fn: str, target: str) -> str:
        if fn == "swing":
            pull = push = swing_t
            vmax = s.swing_motor.speed_limit(s.pump_flow_m3_s)
            v_ret, v_ext = vmax, vmax
            lo, hi = a.lower[0], a.upper[0]
        else:
            cyl = s.cylinder(fn)
            pull, push = cyl.force_limits(s.relief_pa)
            v_ret, v_ext = cyl.speed_limits(s.pump_flow_m3_s)
            lo, hi = cyl.retracted_m, cyl.extended_m
        kv = kp[fn] * s.servo_time_s
        return (f'<general name="{fn}" class="{s.name}" {target} dyntype="integrator" gaintype="fixed" '
                f'biastype="affine" gainprm="{f(kp[fn])}" biasprm="{f(kp[fn] * l0[fn], -kp[fn], -kv)}" '
                f'ctrlrange="{f(-v_ret, v_ext)}" forcerange="{f(-pull, push)}" actlimited="true" '
                f'actrange="{f(lo - l0[fn], hi - l0[fn])}"/>')

    mass_note = "; ".join(f"{k_} {v:g} kg" for k_, v in m.items())
    return f"""<mujoco model="{s.name}">
  <!--
    GENERATED by scripts/make_excavators.py from excavsim/robot/excavators.py ({s.name}): do not edit by hand.
    The machine only; scene.xml adds the soil pit, lights and keyframes. Every number and its source or
    assumption is in README.md. Bodies are written in the reference pose (the joints' ref, qpos0).
    Masses: {mass_note}; bucket {b.mass_kg:g} kg.
  -->
  <compiler angle="radian" autolimits="true"/>

  <option timestep="0.002" integrator="implicitfast"/>

  <default>
    <default class="{s.name}">
      <joint axis="0 -1 0" damping="{f(200 * scale ** 4)}" armature="{f(5 * scale ** 4)}"/>
      <default class="visual">
        <geom contype="0" conaffinity="0" group="2" density="0"/>
      </default>
      <default class="collision">
        <!-- The machine collides with the pit's walls (conaffinity 2), not with itself or the soil
             heightfield: the soil model computes every bucket-soil force. -->
        <geom contype="2" conaffinity="0" group="3" density="0" rgba="0.4 0.6 0.4 0.3"/>
      </default>
      <default class="pin">
        <site group="4" size="{f(0.03 * scale)}" rgba="0.9 0.9 0.1 1"/>
      </default>
      <default class="sensor_site">
        <site group="4" size="{f(0.03 * scale)}" rgba="1 0.3 0.1 1"/>
      </default>
      <default class="profile">
        <site group="4" size="{f(0.012 * scale)}" rgba="0.1 0.8 1 1"/>
      </default>
      <default class="tip">
        <site group="4" size="{f(0.02 * scale)}" rgba="1 0 0 1"/>
      </default>
    </default>
  </default>

  <asset>
    <material name="{s.name}_yellow" rgba="0.95 0.7 0.1 1"/>
    <material name="{s.name}_dark" rgba="0.15 0.15 0.17 1"/>
    <material name="{s.name}_steel" rgba="0.55 0.55 0.58 1"/>
  </asset>

  <worldbody>
    <body name="base" childclass="{s.name}">
      <!-- tracks: fixed to the ground while digging (no joint) -->
      <geom name="track_left" class="visual" type="box" size="{f(1.0 * scale, 0.2 * scale, s.upper_z_m / 2)}"
            pos="{f(0, 0.55 * scale, s.upper_z_m / 2)}" material="{s.name}_dark"/>
      <geom name="track_right" class="visual" type="box" size="{f(1.0 * scale, 0.2 * scale, s.upper_z_m / 2)}"
            pos="{f(0, -0.55 * scale, s.upper_z_m / 2)}" material="{s.name}_dark"/>
      <body name="upper" pos="{f(0, 0, s.upper_z_m)}">
        <inertial pos="{f(-0.3 * scale, 0, 0.4 * scale)}" mass="{f(m['upper'])}"
                  diaginertia="{box_inertia(m['upper'], (2.0 * scale, 1.5 * scale, 1.0 * scale))}"/>
        <joint name="swing_joint" axis="0 0 1" range="{f(a.lower[0], a.upper[0])}" ref="{f(ref[0])}"
               damping="{f(2000 * scale ** 4)}" armature="{f(200 * scale ** 4)}"/>
        <geom name="cab" class="visual" type="box" size="{f(0.4 * scale, 0.35 * scale, 0.6 * scale)}"
              pos="{f(0.0, 0.35 * scale, 0.7 * scale)}" material="{s.name}_yellow"/>
        <geom name="counterweight" class="visual" type="box" size="{f(0.35 * scale, 0.7 * scale, 0.35 * scale)}"
              pos="{f(-0.75 * scale, 0, 0.35 * scale)}" material="{s.name}_dark"/>
        <geom name="upper_collision" class="collision" type="box" size="{f(0.9 * scale, 0.7 * scale, 0.2 * scale)}"
              pos="{f(-0.3 * scale, 0, 0.2 * scale)}"/>
        <!-- Two laser range finders on the cab roof looking ahead and down (Rowe 1997 §6.1, Fig. 10). -->
        <site name="cab_scanner_left" class="sensor_site" pos="{f(0.3 * scale, 0.6 * scale, 1.35 * scale)}"
              zaxis="1 0 -0.8"/>
        <site name="cab_scanner_right" class="sensor_site" pos="{f(0.3 * scale, -0.6 * scale, 1.35 * scale)}"
              zaxis="1 0 -0.8"/>
        <site name="boom_cylinder_base" class="pin" pos="{xz(foot + np.array(boom_a))}"/>
        <body name="boom" pos="{xz(foot)}" quat="{quat_y(ref[1])}">
          <inertial pos="{f(l1 * 0.45, 0, 0.05 * scale)}" mass="{f(m['boom'])}"
                    diaginertia="{box_inertia(m['boom'], (l1, 0.3 * scale, 0.35 * scale))}"/>
          <joint name="boom_joint" range="{f(a.lower[1], a.upper[1])}" ref="{f(ref[1])}"/>
          <geom name="boom_shell" class="visual" type="box" size="{f(l1 / 2, 0.12 * scale, 0.15 * scale)}"
                pos="{f(l1 / 2, 0, 0)}" material="{s.name}_yellow"/>
          <geom name="boom_collision" class="collision" type="capsule" size="{f(0.15 * scale)}"
                fromto="{f(0.2 * scale, 0, 0, l1 - 0.2 * scale, 0, 0)}"/>
          <site name="boom_cylinder_rod" class="pin" pos="{xz(boom_b)}"/>
          <site name="stick_cylinder_base" class="pin" pos="{xz(np.array([l1, 0.0]) + stick_a)}"/>
          <body name="stick" pos="{f(l1, 0, 0)}" quat="{quat_y(ref[2])}">
            <inertial pos="{f(l2 * 0.4, 0, 0)}" mass="{f(m['stick'])}"
                      diaginertia="{box_inertia(m['stick'], (l2, 0.2 * scale, 0.25 * scale))}"/>
            <joint name="stick_joint" range="{f(a.lower[2], a.upper[2])}" ref="{f(ref[2])}"/>
            <geom name="stick_shell" class="visual" type="box" size="{f(l2 / 2 + 0.15 * scale, 0.1 * scale, 0.11 * scale)}"
                  pos="{f(l2 / 2 - 0.15 * scale, 0, 0)}" material="{s.name}_yellow"/>
            <geom name="stick_collision" class="collision" type="capsule" size="{f(0.11 * scale)}"
                  fromto="{f(0.1 * scale, 0, 0, l2 - 0.2 * scale, 0, 0)}"/>
            <site name="stick_cylinder_rod" class="pin" pos="{xz(stick_b)}"/>
            <site name="bucket_cylinder_base" class="pin" pos="{xz(np.array([l2, 0.0]) + lk.cylinder_base)}"/>
            <body name="bucket" pos="{f(l2, 0, 0)}" quat="{quat_y(ref[3])}">
              <inertial pos="{xz(centroid)}" mass="{f(b.mass_kg)}"
                        diaginertia="{box_inertia(b.mass_kg, (b.depth_m, w, b.back_m))}"/>
              <joint name="bucket_joint" range="{f(a.lower[3], a.upper[3])}" ref="{f(ref[3])}"/>
              <site name="ft_mount" class="sensor_site"/>
              <geom name="bucket_shell" class="visual" type="box" size="{f(l3 / 2, w / 2, 0.05 * scale)}"
                    pos="{xz(centroid)}" xyaxes="{f(math.cos(ba), 0, math.sin(ba), 0, 1, 0)}" material="{s.name}_steel"/>
              {chr(10).join('              ' + x for x in boxes).strip()}
{chr(10).join(f'              <site name="bucket_profile_{i}" class="profile" pos="{xz(p)}"/>' for i, p in enumerate(profile))}
              <!-- Tip frame: x along the blade from heel to cutting edge, z normal to the blade into the
                   bucket, y the arm plane's -y (the T3's convention). -->
              <site name="bucket_tip" class="tip" pos="{xz(tip)}" xyaxes="{f(math.cos(ba), 0, math.sin(ba), 0, -1, 0)}"/>
            </body>
            <body name="rocker" pos="{xz(np.array([l2, 0.0]) + k)}" quat="{quat_y(rho)}">
              <inertial pos="{f(lk.rocker_m / 2, 0, 0)}" mass="{f(m['rocker'])}"
                        diaginertia="{box_inertia(m['rocker'], (lk.rocker_m, 0.1 * scale, 0.05 * scale))}"/>
              <joint name="rocker_joint" ref="{f(rho)}" damping="{f(5 * scale ** 4)}" armature="{f(LINKAGE_ARMATURE * scale ** 4)}"/>
              <geom name="rocker_shell" class="visual" type="box" size="{f(lk.rocker_m / 2, 0.06 * scale, 0.03 * scale)}"
                    pos="{f(lk.rocker_m / 2, 0, 0)}" material="{s.name}_steel"/>
              <site name="bucket_cylinder_rod" class="pin" pos="{f(lk.rocker_m, 0, 0)}"/>
              <body name="link" pos="{f(lk.rocker_m, 0, 0)}" quat="{quat_y(lam - rho)}">
                <inertial pos="{f(lk.link_m / 2, 0, 0)}" mass="{f(m['link'])}"
                          diaginertia="{box_inertia(m['link'], (lk.link_m, 0.1 * scale, 0.05 * scale))}"/>
                <joint name="link_joint" ref="{f(lam - rho)}" damping="{f(5 * scale ** 4)}" armature="{f(LINKAGE_ARMATURE * scale ** 4)}"/>
                <geom name="link_shell" class="visual" type="box" size="{f(lk.link_m / 2, 0.05 * scale, 0.03 * scale)}"
                      pos="{f(lk.link_m / 2, 0, 0)}" material="{s.name}_steel"/>
              </body>
            </body>
          </body>
        </body>
      </body>
    </body>
  </worldbody>

  <equality>
    <!-- The bucket linkage's loop: the link's end is pinned to the bucket (at the reference pose the two
         points coincide; MuJoCo holds them together). -->
    <connect name="bucket_link_pin" body1="link" body2="bucket" anchor="{f(lk.link_m, 0, 0)}"
             solref="0.004 1" solimp="0.999 0.9999 0.001"/>
  </equality>

  <tendon>
    <!-- The cylinders, pin to pin: MuJoCo's tendon length is the cylinder's length. -->
    <spatial name="boom_cylinder" width="{f(0.04 * scale)}" rgba="0.6 0.6 0.65 1">
      <site site="boom_cylinder_base"/>
      <site site="boom_cylinder_rod"/>
    </spatial>
    <spatial name="stick_cylinder" width="{f(0.035 * scale)}" rgba="0.6 0.6 0.65 1">
      <site site="stick_cylinder_base"/>
      <site site="stick_cylinder_rod"/>
    </spatial>
    <spatial name="bucket_cylinder" width="{f(0.033 * scale)}" rgba="0.6 0.6 0.65 1">
      <site site="bucket_cylinder_base"/>
      <site site="bucket_cylinder_rod"/>
    </spatial>
  </tendon>

  <actuator>
    <!-- Hydraulic servos: ctrl = set-point rate [m/s, rad/s for the swing], bounded by the pump's flow;
         act = set-point minus the reference pose's length, within the stroke; force clipped at the relief
         pressure times the annulus (pull) and piston (push) areas [N; N m for the swing]. -->
    {actuator("swing", 'joint="swing_joint"')}
    {actuator("boom", 'tendon="boom_cylinder"')}
    {actuator("stick", 'tendon="stick_cylinder"')}
    {actuator("bucket", 'tendon="bucket_cylinder"')}
  </actuator>

  <sensor>
    <!-- The wrench between stick and bucket at the bucket pin, in the bucket's frame (the link's load enters
         the bucket at the link pin, so this is not the soil's wrench; the cylinder forces give that). -->
    <force name="ft_force" site="ft_mount"/>
    <torque name="ft_torque" site="ft_mount"/>
    <!-- Each cylinder's force (what the pressure transducers on its two chambers give) [N]. -->
    <actuatorfrc name="swing_torque" actuator="swing"/>
    <actuatorfrc name="boom_cylinder_force" actuator="boom"/>
    <actuatorfrc name="stick_cylinder_force" actuator="stick"/>
    <actuatorfrc name="bucket_cylinder_force" actuator="bucket"/>
  </sensor>

  <custom>
    <!-- inner width [m], struck capacity [m^3] (excavsim.robot.excavators.BucketShape) -->
    <numeric name="bucket_width" data="{f(w)}"/>
    <numeric name="bucket_capacity" data="{f(b.struck_capacity_m3())}"/>
  </custom>
</mujoco>
"""


# The soil pit of each machine: inner size (square) [m], depth below the ground [m], centre's x [m],
# heightfield samples per side. Assumed: room for a trench and a face within each machine's reach.
PITS = {"tb035": (4.0, 1.5, 3.2, 81), "excavator_25t": (12.0, 4.0, 8.5, 121)}


def keyframes(s: ExcavatorSpec) -> dict[str, np.ndarray]:
    """The scene's keyframes as (swing, boom, stick, bucket) [rad]."""
    if s.name == "tb035":
        return {"home": np.array([0.0, 0.35, -1.6, -1.2]), "park": np.array([0.0, 1.0, -2.5, -2.5])}
    # dump: swung to Rowe 1997 Fig. 4's truck at 101 deg, the bucket open above a truck bed's height
    return {"home": np.array([0.0, 0.37, -1.55, -1.2]), "park": np.array([0.0, 1.0, -2.5, -2.4]),
            "dump": np.array([np.radians(101.0), 0.8, -1.2, 0.5])}


def key_line(s: ExcavatorSpec, name: str, q: np.ndarray) -> str:
    qpos, act = s.rest_state(q)  # swing, boom, stick, bucket, rocker, link (tree order); the servos' states
    return f'<key name="{name}" qpos="{f(qpos)}" act="{f(act)}" ctrl="0 0 0 0"/>'


def scene_xml(s: ExcavatorSpec) -> str:
    side, depth, cx, n = PITS[s.name]
    h = side / 2
    ground = 10.0 * side
    elevation = depth + 1.0
    keys = "\n    ".join(key_line(s, k, q) for k, q in keyframes(s).items())
    targets_geoms, targets_sites = [], []
    # The pit is filled flush with the ground and has no walls above the soil (the T3's box has), so the
    # surveyed targets lie flat on the ground around its rim, a tenth of its side out, 1 mm proud of the
    # ground (the soil_box body sits on the pit's floor, the ground at z = depth in its frame), at
    # different ranges from the scanner.
    rim = h + 0.1 * side
    pts = [(-0.5 * h, rim), (0.5 * h, rim), (-0.5 * h, -rim), (0.5 * h, -rim),
           (rim, -0.4 * h), (rim, 0.4 * h), (-0.8 * h, rim), (0.8 * h, -rim)]
    for i, (x, y) in enumerate(pts):
        plate, site, zaxis = (x, y, depth + 0.001), (x, y, depth + 0.002), f(0, 0, 1)
        targets_geoms.append(f'<geom name="survey_target_{i}_plate" class="survey_target" pos="{f(plate)}" zaxis="{zaxis}"/>')
        targets_sites.append(f'<site name="survey_target_{i}" class="survey_target" pos="{f(site)}"/>')
    tg = "\n      ".join(targets_geoms)
    ts = "\n      ".join(targets_sites)
    return f"""<mujoco model="{s.name} scene">
  <!-- GENERATED by scripts/make_excavators.py: the {s.name} beside a soil pit sunk into the ground.
       The pit carries the testbed's soil names (the soil hfield and geom, the soil_box body, the survey
       targets and the fixed scanner), so the world's soil model and scanner apply to it unchanged. -->
  <include file="{s.name}.xml"/>

  <statistic center="{f(cx * 0.6, 0, 0)}" extent="{f(side * 1.5)}"/>

  <visual>
    <headlight diffuse="0.6 0.6 0.6" ambient="0.3 0.3 0.3" specular="0 0 0"/>
    <global azimuth="-60" elevation="-25"/>
  </visual>

  <default>
    <default class="pit">
      <default class="ground">
        <!-- Ground slabs around the pit; their tops are at z = 0. The machine's collision geoms
             (contype 2) hit them. -->
        <geom type="box" contype="0" conaffinity="2" group="1" rgba="0.45 0.42 0.35 1"/>
      </default>
      <default class="survey_target">
        <geom type="box" size="0.04 0.04 0.001" contype="0" conaffinity="0" group="1" rgba="0.95 0.95 0.95 1"/>
        <site group="4" size="0.01" rgba="1 0 1 1"/>
      </default>
    </default>
  </default>

  <asset>
    <texture type="skybox" builtin="gradient" rgb1="0.3 0.5 0.7" rgb2="0 0 0" width="512" height="3072"/>
    <!-- soil: {n} x {n} samples over {side:g} m; the floor {depth:g} m below the ground, heights up to
         {elevation:g} m above it -->
    <hfield name="soil" nrow="{n}" ncol="{n}" size="{f(h, h, elevation, 0.05)}"/>
    <texture name="sand" type="2d" builtin="flat" rgb1="0.76 0.66 0.48" width="64" height="64"
             mark="random" random="0.15" markrgb="0.62 0.52 0.36"/>
    <material name="sand" texture="sand" texrepeat="8 8"/>
  </asset>

  <worldbody>
    <light pos="{f(cx, 0, 20)}" dir="0 0 -1" directional="true"/>
    <body name="soil_box" pos="{f(cx, 0, -depth)}" childclass="pit">
      <geom name="soil" type="hfield" hfield="soil" contype="0" conaffinity="0" group="0" material="sand"/>
      <geom name="ground_front" class="ground" size="{f(ground, (ground - h) / 2, depth / 2)}"
            pos="{f(0, h + (ground - h) / 2, depth / 2)}"/>
      <geom name="ground_back" class="ground" size="{f(ground, (ground - h) / 2, depth / 2)}"
            pos="{f(0, -h - (ground - h) / 2, depth / 2)}"/>
      <geom name="ground_near" class="ground" size="{f((ground - h) / 2, h, depth / 2)}"
            pos="{f(-h - (ground - h) / 2, 0, depth / 2)}"/>
      <geom name="ground_far" class="ground" size="{f((ground - h) / 2, h, depth / 2)}"
            pos="{f(h + (ground - h) / 2, 0, depth / 2)}"/>
      <!-- Surveyed targets lying on the ground around the pit's rim, for the scanner's calibration. -->
      {tg}
      {ts}
      <!-- A fixed scanner on a mast beside the pit (the testbed's name); the machine's own range finders
           are the cab_scanner_* sites. -->
      <site name="scanner" pos="{f(0, -h - 1.5, depth + 3.0)}" zaxis="{f(0, h + 1.5, -3.0 - depth)}" group="4"
            size="0.03" rgba="0 1 0 1"/>
    </body>
  </worldbody>

  <keyframe>
    <!-- qpos: swing, boom, stick, bucket, rocker, link [rad] (the linkage's angles follow from the
         bucket's); act: the set-points minus the reference pose's (swing [rad], cylinders [m]). -->
    {keys}
  </keyframe>
</mujoco>
"""


def outputs() -> dict[pathlib.Path, str]:
    """Every file this script writes, with its text."""
    out = {}
    for name, spec in MACHINES.items():
        out[MODELS / name / f"{name}.xml"] = machine_xml(spec)
        out[MODELS / name / "scene.xml"] = scene_xml(spec)
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="only report files that differ; exit 1 if any")
    args = parser.parse_args()
    stale = []
    for path, text in outputs().items():
        if path.exists() and path.read_text() == text:
            continue
        stale.append(path)
        if not args.check:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text)
            print(f"wrote {path.relative_to(ROOT)}")
    if args.check and stale:
        print("stale: " + ", ".join(str(p.relative_to(ROOT)) for p in stale))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
