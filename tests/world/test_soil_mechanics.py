"""The phenomena of the world's soil model as properties (issue 23 items 1-3).

Speed from the dynamic earthmoving equation (McKyes 1985) and the rate effect on cohesion; the
saw-tooth from the wedge's failure cycle, spaced ``d cot beta*`` and scaled by the local strength;
the surcharge from soil heaped ahead, so that drags in cohesionless sand scale as ``d^2``; no
bearing spike from the entry; volume conservation and determinism with every term on.
Drags are the kinematic drives of :mod:`excavsim.studies.figures.drags` (the soil model alone, no servo).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from excavsim.config import get_soil
from excavsim.studies.figures import drags
from excavsim.mechanics.wedge import critical_beta, wedge_denominator, wedge_force
from excavsim.mechanics.wedge_inertia import inertial_force
from excavsim.world.simulation import Simulation

RAKE = math.radians(30)
QUIET = {"cohesion_rate_per_decade": 0.0, "brittleness_index": 0.0, "heterogeneity_std": 0.0,
         "ft_force_noise_n": 0.0, "ft_torque_noise_nm": 0.0}


def world(seed: int = 0, soil: str | None = None, load_surcharge: bool = False, **truth) -> Simulation:
    """A fresh world whose truth terms are off unless given, and the load's surcharge on the wedge
    (issue 35) off unless asked: these properties isolate the other terms (tests/world/test_soil.py
    checks the load's term along a drag)."""
    scene = drags.scene_with_truth(**{**QUIET, **truth})
    scene = scene.model_copy(update={"bucket": scene.bucket.model_copy(update={"load_surcharge": load_surcharge})})
    if soil is not None:
        scene = scene.model_copy(update={"soil": soil})
    return Simulation(scene=scene, seed=seed)


def recorded(sim: Simulation) -> list:
    """Keep every SoilContact the soil model returns from now on."""
    contacts = []
    step = sim.soil.step

    def keep(data, dt):
        c = step(data, dt)
        contacts.append(c)
        return c

    sim.soil.step = keep
    return contacts


def steady_failure_force(sim: Simulation, *, depth: float, speed: float, length: float = 0.2) -> tuple[float, float]:
    """Mean wedge failure force [N] and mean advance speed [m/s] over the second half of a drag."""
    contacts = recorded(sim)
    rec = drags.horizontal_drag(sim, x0_m=2.4, length_m=length, depth_m=depth, rake_rad=RAKE, speed_m_s=speed)
    tail = contacts[-(len(rec.s_m) // 2):]
    return (float(np.mean([c.wedge_failure_force_n for c in tail])),
            float(np.mean([c.advance_speed_m_s for c in tail])))


def failure_positions(contacts) -> np.ndarray:
    """x [m] of the edge centre at the steps where the wedge failed."""
    return np.array([c.record["edge_centre_m"][0][0] for c in contacts if c.wedge_failed])


def test_force_rises_with_speed_with_positive_curvature_as_the_dynamic_earthmoving_equation():
    """Sand (c = 0): F(v) = eq. 8 + rho v^2 d N_acc w; equally spaced speeds give a convex, rising curve."""
    speeds = (0.1, 0.5, 0.9, 1.3)
    soil = get_soil("testbed_sand")
    f, v_adv = zip(*(steady_failure_force(world(), depth=0.1, speed=v) for v in speeds))
    f = np.array(f)
    assert np.all(np.diff(f) > 0), f
    assert np.all(np.diff(f, 2) > 0), f  # positive curvature: the v^2 of the inertial term
    width = Simulation(seed=0).soil.bucket.width
    expect = [float(wedge_force(0.1, RAKE, soil, width) + inertial_force(0.1, RAKE, v, soil, width)) for v in v_adv]
    np.testing.assert_allclose(f, expect, rtol=0.01)
    np.testing.assert_allclose(v_adv, speeds, rtol=0.05)  # the drive's whole steps per segment


def test_cohesion_grows_with_the_log_of_the_advance_speed_in_clay():
    """Lean clay: the cohesive part of eq. 8 times 1 + k log10(v / v_ref) (k = 0.1 per decade), plus inertia."""
    soil = get_soil("lean_clay")
    sand_like = soil.model_copy(update={"cohesion_pa": 0.0, "adhesion_pa": 0.0})
    width = Simulation(seed=0).soil.bucket.width
    for v in (0.005, 0.1, 0.8):
        f, v_adv = steady_failure_force(world(soil="lean_clay", cohesion_rate_per_decade=0.1), depth=0.06, speed=v,
                                        length=0.12)
        rate = 1.0 + 0.1 * math.log10(max(v_adv, 0.01) / 0.01)
        weight = float(wedge_force(0.06, RAKE, sand_like, width))
        cohesive = float(wedge_force(0.06, RAKE, soil, width)) - weight
        expect = weight + rate * cohesive + float(inertial_force(0.06, RAKE, v_adv, soil, width))
        assert f == pytest.approx(expect, rel=0.01), v


@pytest.mark.parametrize("depth", [0.08, 0.12])
def test_failures_are_spaced_d_cot_beta_in_uniform_sand(depth):
    """Fig. 54: the wedge fails every d cot beta* of advance (within 20 %), each drop the brittleness index."""
    sim = world(brittleness_index=0.2)
    contacts = recorded(sim)
    drags.horizontal_drag(sim, x0_m=2.4, length_m=0.7, depth_m=depth, rake_rad=RAKE)
    expect = depth / math.tan(float(critical_beta(RAKE, math.radians(30), math.radians(30))))
    x = failure_positions(contacts)
    spacing = -np.diff(x)[-3:]  # the last three cycles, at the drag's depth
    assert len(x) >= 5
    np.testing.assert_allclose(spacing, expect, rtol=0.2)
    f = np.array([np.linalg.norm(c.cutting_force) for c in contacts])
    i = [k for k, c in enumerate(contacts) if c.wedge_failed][-1]
    assert f[i + 1] == pytest.approx(0.8 * f[i], rel=0.01)  # the drop: I_B = 0.2 of the peak


@pytest.mark.parametrize("strength", [0.7, 1.3])
def test_failure_spacing_scales_with_the_local_soil_strength(strength):
    """A stronger soil takes more advance to load the next wedge to failure: spacing = s d cot beta*."""
    sim = world(brittleness_index=0.2)
    sim.soil.strength[:] = strength
    contacts = recorded(sim)
    drags.horizontal_drag(sim, x0_m=2.4, length_m=0.7, depth_m=0.1, rake_rad=RAKE)
    expect = strength * 0.1 / math.tan(float(critical_beta(RAKE, math.radians(30), math.radians(30))))
    np.testing.assert_allclose(-np.diff(failure_positions(contacts))[-2:], expect, rtol=0.05)


def test_cohesionless_drags_scale_as_depth_squared_where_nothing_heaps():
    """Quiet sand, a short drag (the bucket far from full, nothing spilled ahead): F ~ d^2 as eq. 8."""
    depths = np.array([0.05, 0.10, 0.15])
    forces = []
    for d in depths:
        rec = drags.horizontal_drag(world(), x0_m=2.4, length_m=0.2, depth_m=float(d), rake_rad=RAKE)
        forces.append(rec.magnitude_n[len(rec.s_m) // 2:].mean())
    slope = np.polyfit(np.log(depths), np.log(forces), 1)[0]
    assert slope == pytest.approx(2.0, abs=0.03)


def test_soil_heaped_ahead_of_the_blade_is_the_surcharge():
    """A heap on the wedge ahead of the edge adds its weight over eq. 5's denominator, gamma g V / D (eq. 7)."""
    sim = world()
    contacts = recorded(sim)
    drive = drags.KinematicDrive(sim)
    z = drags.SURFACE_Z_M - 0.1
    drive.line((2.4, drags.SURFACE_Z_M + 0.02, RAKE), (2.2, z, RAKE), 0.1)
    drive.line((2.2, z, RAKE), (2.1, z, RAKE), 0.1)
    before = contacts[-1]
    g = sim.soil.grid
    ex = before.record["edge_centre_m"][0][0]
    xs, ys = g.x0 + np.arange(g.shape[1]) * g.cell, g.y0 + np.arange(g.shape[0]) * g.cell
    block = np.ix_(np.abs(ys) < 0.1, (xs > ex - 0.28) & (xs < ex - 0.1))  # inside the wedge's 0.35 m ahead
    g.heights[block] += 0.04
    volume = 0.04 * g.heights[block].size * g.cell ** 2
    drive.place((2.1, z, RAKE))  # the same pose: only the heap differs
    after = contacts[-1]
    phi = math.radians(30)
    beta = float(critical_beta(RAKE, phi, phi))
    gain = sim.soil.params["gamma_g_n_m3"][0] * volume / float(wedge_denominator(RAKE, beta, phi, phi))
    assert after.wedge_failure_force_n - before.wedge_failure_force_n == pytest.approx(gain, rel=0.1)


@pytest.mark.parametrize(("depth", "length"), [(0.10, 0.3), (0.15, 0.2), (0.20, 0.05)])
def test_no_force_sample_above_the_wedge_force_in_quiet_sand(depth, length):
    """The entry along rake - epsilon keeps the heel in the edge's slot: no bearing transient (it was 1.8 kN
    at 10 cm, 7.6 kN at 20 cm), and no sample above 1.05 x (eq. 8 + inertia) while nothing heaps (the
    drags end before the 25.5 l heaped bucket is full: at 20 cm the entry alone cuts 16 l), with the
    load's surcharge on: its bearing share at the drag's final load bounds it (kernels.load_surcharge_volume)."""
    from excavsim.mechanics.wedge import surcharge_force
    from excavsim.world.kernels import load_surcharge_volume

    sim = world(brittleness_index=0.2, load_surcharge=True)
    contacts = recorded(sim)
    rec = drags.horizontal_drag(sim, x0_m=2.4, length_m=length, depth_m=depth, rake_rad=RAKE)
    assert sim.soil.load < sim.soil.heaped_capacity
    soil, width = get_soil("testbed_sand"), sim.soil.bucket.width
    load = float(surcharge_force(load_surcharge_volume(sim.soil.load, sim.soil.heaped_capacity), RAKE, soil))
    assert load > 0.0
    bound = 1.05 * float(wedge_force(depth, RAKE, soil, width) + inertial_force(depth, RAKE, 0.1, soil, width) + load)
    assert rec.magnitude_n.max() <= bound, (rec.magnitude_n.max(), bound)
    assert max(np.linalg.norm(c.bearing_force) for c in contacts) < 1.0


def test_a_drag_with_every_term_conserves_soil_and_is_reproducible_for_a_seed():
    def run(seed):
        sim = Simulation(seed=seed)  # the configured truth: failure cycle, heterogeneity, rate effect
        v0 = sim.soil.volumes().total
        rec = drags.horizontal_drag(sim, x0_m=2.4, length_m=0.5, depth_m=0.15, rake_rad=RAKE)
        assert sim.soil.volumes().total == pytest.approx(v0, abs=1e-12)
        return rec.force_plane_n

    a = run(7)
    np.testing.assert_array_equal(a, run(7))
    assert not np.array_equal(a, run(8))
